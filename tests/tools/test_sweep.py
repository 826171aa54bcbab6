"""gw.sweep and ``python -m grasswidget sweep``: each cell against a GrassScene run with
those parameters, the labelled picture, and bad input refused before any GPU work."""

import numpy as np
import pytest
from PIL import Image

import grasswidget as gw
from grasswidget.core.blade_response import response_summary
from grasswidget.tools import cli

BLADES, SIZE, STEPS = 256, (80, 60), 40


def _scene_run(**values):
    """What a fresh GrassScene with these parameters shows after STEPS steps."""
    from grasswidget.gpu.scene import GrassScene, adapter_params

    scene = GrassScene(gw.Blades.on_plane(BLADES, seed=0), size=SIZE, params=adapter_params(**values))
    try:
        scene.step(STEPS)
        summary = response_summary(scene.field.read_state())
        img = scene.render_at(SIZE)
        return summary, scene.visible_count(), img
    finally:
        scene.release()


@pytest.fixture(scope="module")
def grid():
    return gw.sweep({"stiffness_scale": [0.5, 2.0], "wind_strength": [0.0, 30.0]}, steps=STEPS, blades=BLADES,
                    size=SIZE, progress=False)


def test_grid_cells_equal_fresh_scenes_with_those_parameters(grid):
    assert grid.shape == (2, 2)
    assert list(grid.data["stiffness_scale"]) == [0.5, 2.0] and list(grid.data["wind_strength"]) == [0.0, 30.0]
    for key in ("mean_tip_offset", "mean_bend_deg", "blades_drawn"):
        assert grid.data[key].shape == (2, 2)
    # two opposite corners: the reused scene's cell is a fresh scene's run (the first cell's
    # values are undone before the last one)
    for (r, c), values in (((0, 0), dict(stiffness_scale=0.5, wind_strength=0.0)),
                           ((1, 1), dict(stiffness_scale=2.0, wind_strength=30.0))):
        summary, drawn, img = _scene_run(**values)
        assert grid.data["mean_tip_offset"][r, c] == pytest.approx(summary["mean_tip_offset"], rel=1e-6)
        assert grid.data["mean_bend_deg"][r, c] == pytest.approx(summary["mean_bend_deg"], rel=1e-6)
        assert grid.data["blades_drawn"][r, c] == drawn
        assert np.abs(grid.cells[r, c].astype(int) - img.astype(int)).max() <= 2
    # physics: stiffer grass stands straighter, wind bends it further
    tip = grid.data["mean_tip_offset"]
    assert tip[1, 0] < tip[0, 0] and tip[1, 1] < tip[0, 1]
    assert tip[1, 1] > tip[1, 0]
    assert 0 < grid.data["blades_drawn"].min() <= grid.data["blades_drawn"].max() <= BLADES


def test_sheet_has_the_cells_and_labels_and_saves_a_png(grid, tmp_path):
    img = grid.image
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 4
    h, w = SIZE[1], SIZE[0]
    assert img.shape[0] > 2 * h and img.shape[1] > 2 * w
    # every cell's picture appears in the sheet, pixel for pixel
    for r in range(2):
        for c in range(2):
            cell = grid.cells[r, c]
            found = np.argwhere(np.all(img[:, :, :3] == cell[0, 0, :3], axis=2))
            assert any(np.array_equal(img[y:y + h, x:x + w], cell) for y, x in found[:400])
    # labels: dark text pixels left of the cells (row labels) and above them (column labels)
    assert (img[:, :20, :3] < 100).any() and (img[:25, :, :3] < 100).any()
    from IPython.core.formatters import PNGFormatter

    png = PNGFormatter()(grid)  # what a notebook shows
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    path = grid.save(tmp_path / "sheet.png")
    assert np.array_equal(np.asarray(Image.open(path).convert("RGBA")), img)


def test_one_parameter_is_a_row():
    row = gw.sweep({"stiffness_scale": [1.0, 4.0]}, steps=10, blades=64, size=(48, 36), progress=False)
    assert row.shape == (1, 2) and row.data["mean_tip_offset"].shape == (2,)
    assert row.data["mean_tip_offset"][1] < row.data["mean_tip_offset"][0]


@pytest.mark.parametrize("axes, error, words", [
    ({}, gw.GrassValueError, "empty"),
    ({"stiffness_scale": []}, gw.GrassValueError, "stiffness_scale.*empty"),
    ({"stiffness_scale": [1], "gravity": [1], "wind_speed": [1]}, gw.GrassValueError, "1 parameter .* or 2"),
    ({"stiffness_scale": [0.5, 99]}, gw.ParameterError, r"stiffness_scale must be .*\[0.01, 20\]"),
    ({"stifness_scale": [1]}, gw.UnknownNameError, "did you mean 'stiffness_scale'"),
    ({"stiffness_scale": 2}, gw.GrassTypeError, "must be a list"),
    ({"stiffness_scale": list(range(1, 10)), "gravity": list(range(1, 10))}, gw.GrassValueError, "at most 64"),
])
def test_bad_sweeps_raise_before_any_gpu_work(monkeypatch, axes, error, words):
    import grasswidget.gpu.scene as scene_module

    def no_gpu(*args, **kwargs):
        raise AssertionError("a GrassScene was made for a bad sweep")

    monkeypatch.setattr(scene_module, "GrassScene", no_gpu)
    with pytest.raises(error, match=words):
        gw.sweep(axes, blades=64, progress=False)


def test_cli_sweep_writes_the_sheet_and_refuses_bad_values(tmp_path, capsys):
    out = tmp_path / "new" / "sweep.png"
    rc = cli.main(["sweep", str(out), "--vary", "stiffness_scale=0.5,2", "--blades", "64", "--size", "48x36",
                   "--steps", "10", "--no-progress"])
    assert rc == 0
    img = np.asarray(Image.open(out).convert("RGBA"))
    assert img.shape[1] > 2 * 48 and img.shape[0] > 36
    assert img[..., :3].std() > 10  # grass and sky, not a blank picture
    text = capsys.readouterr().out
    assert "stiffness_scale=0.5: mean tip offset" in text and "stiffness_scale=2: " in text
    with pytest.raises(SystemExit) as ex:
        cli.main(["sweep", str(out), "--vary", "stiffness_scale=0,2"])
    assert ex.value.code == 2
    assert "stiffness_scale must be a finite number in [0.01, 20]" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["sweep", str(tmp_path / "x.jpg"), "--vary", "stiffness_scale=1"])
    assert "must end in .png" in capsys.readouterr().err


def test_a_preset_sweep_uses_the_presets_field_and_camera():
    """The cis565 preset: its field of the given count and its camera (from (0, 1, 10)): the
    grass fills the lower part of each cell, sky above."""
    row = gw.sweep({"gravity": [2.0, 20.0]}, steps=20, blades=512, preset="cis565", size=(64, 48), progress=False)
    assert row.blades == 512 and row.shape == (1, 2)
    assert row.data["mean_bend_deg"][1] > row.data["mean_bend_deg"][0]  # more gravity, more bend
    from conftest import grass_mask, sky_mask

    cell = row.cells[0, 0]
    assert grass_mask(cell[24:]).mean() > 0.3 and sky_mask(cell[:8]).mean() > 0.5
