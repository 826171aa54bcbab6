"""``grasswidget bench --matrix``: the defaults against every fixed combination, interleaved."""

import json

import pytest

from grasswidget.errors import GrassValueError
from grasswidget.tools.benchmark_matrix import SETTINGS, format_matrix, run_matrix
from grasswidget.tools.cli import main


def test_matrix_rows_settings_and_json(tmp_path, capsys):
    path = tmp_path / "m.json"
    assert main(["bench", "--matrix", "--preset", "cis565", "--blades", "1024", "--size", "80x60", "--rounds", "2",
                 "--block", "1", "--no-progress", "--json", str(path)]) == 0
    report = json.loads(path.read_text())
    (row,) = report["results"]
    assert set(row["frame_ms"]) == {name for name, _, _ in SETTINGS} and len(SETTINGS) == 5
    assert all(s["frames"] == 2 and 0 < s["p10"] <= s["median"] <= s["p90"] for s in row["frame_ms"].values())
    best = row["best_fixed"]
    assert best != "defaults" and row["frame_ms"][best]["median"] == min(
        s["median"] for name, s in row["frame_ms"].items() if name != "defaults")
    assert row["defaults_over_best"] == pytest.approx(row["frame_ms"][best]["median"] / row["frame_ms"]["defaults"]["median"])
    assert set(row["decisions"]) == {"cull_occlusion", "compute_raster"} and row["trial_frames"] >= 12
    assert len(report["load_average"]["before"]) == 3
    out = capsys.readouterr().out
    assert "defaults/best" in out and f"wrote {path}" in out and format_matrix(report).splitlines()[-1] in out


def test_matrix_refuses_bad_rounds():
    with pytest.raises(GrassValueError, match="rounds must be an integer >= 1"):
        run_matrix("cis565", [64], rounds=0, progress=False)
