"""The traces' recorder (pure NumPy): arrays, the rolling window, files, chart series, culling counts."""

import re
from pathlib import Path

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference
from grasswidget.core.cull_counts import RECOUNT_INTERVAL_S, CullCounter
from grasswidget.core.teaching import camera_view_proj
from grasswidget.core.traces import (CHART_KINDS, CULL_TESTS, MAX_SAMPLES, TraceRecorder, TraceSample, bend_degrees,
                                     load_traces, tip_offset)
from conftest import TickingWall


def _sample(t, step, ids, rng, kept=None):
    k = len(ids)
    v0 = rng.normal(size=(k, 3))
    up = np.tile([0.0, 1.0, 0.0], (k, 1))
    height = rng.uniform(0.5, 2.0, k)
    v2 = v0 + up * height[:, None] + rng.normal(scale=0.1, size=(k, 3))
    return TraceSample(t=t, step_count=step, ids=tuple(ids), v0=v0, v2=v2, up=up, height=height,
                       collision=rng.uniform(0, 1, k), forces=rng.normal(size=(k, 4, 3)),
                       kept=kept or {"orientation": 100, "frustum": 80, "distance": 60, "occlusion": 50},
                       drawn={"ribbons": 45, "compute": 5}, frame_ms={"render": 3.0})


def test_tip_offset_and_bend_against_hand_computed_blades():
    v0 = np.zeros((2, 3))
    up = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    h = np.array([1.0, 2.0])
    v2 = np.array([[0.0, 1.0, 0.0], [2.0 * np.sin(np.radians(30)), 2.0 * np.cos(np.radians(30)), 0.0]])
    np.testing.assert_allclose(tip_offset(v0, v2, up, h), [0.0, np.hypot(1.0, 2.0 - np.sqrt(3.0))], atol=1e-12)
    np.testing.assert_allclose(bend_degrees(v0, v2, up), [0.0, 30.0], atol=1e-9)


def test_traces_arrays_follow_blades_inspected_at_different_times():
    rng = np.random.default_rng(0)
    rec = TraceRecorder()
    a = _sample(0.1, 12, [5, 9], rng)
    b = _sample(0.2, 24, [9, 7], rng)
    rec.record(a)
    rec.record(b)
    tr = rec.traces()
    assert list(tr["ids"]) == [5, 9, 7] and tr["v2"].shape == (2, 3, 3)
    np.testing.assert_array_equal(tr["t"], [0.1, 0.2])
    np.testing.assert_array_equal(tr["step"], [12, 24])
    np.testing.assert_array_equal(tr["v2"][0, :2], a.v2)
    assert np.isnan(tr["v2"][0, 2]).all() and np.isnan(tr["v2"][1, 0]).all()
    np.testing.assert_array_equal(tr["v2"][1, 1], b.v2[0])
    np.testing.assert_array_equal(tr["v2"][1, 2], b.v2[1])
    np.testing.assert_allclose(tr["force"]["wind"][1, 2], np.linalg.norm(b.forces[1, 2]))
    np.testing.assert_allclose(tr["tip_offset"][0, :2], tip_offset(a.v0, a.v2, a.up, a.height))
    assert set(tr["kept"]) == set(CULL_TESTS) and tr["kept"]["frustum"].tolist() == [80, 80]


def test_window_keeps_the_last_seconds_and_a_reset_starts_again():
    rng = np.random.default_rng(1)
    rec = TraceRecorder(window_s=1.0)
    for step in range(1, 301):  # 2.5 s at 120 steps/s
        rec.record(_sample(step / 120, step, [1], rng))
    t = rec.traces()["t"]
    assert t[-1] == pytest.approx(2.5) and t[0] >= 1.5 - 1e-9 and t[0] < 1.5 + 1 / 120
    assert len(rec) == 121
    rec.window_s = 0.5  # shrinking the window drops at once
    assert rec.traces()["t"][0] >= 2.0 - 1e-9
    rec.record(_sample(2.5, 300, [1], rng))  # same step again: replaces the last
    assert len(rec) == 61
    rec.record(_sample(0.0 + 1 / 120, 1, [1], rng))  # time went back: reset_blades()
    assert len(rec) == 1 and rec.traces()["step"].tolist() == [1]
    assert MAX_SAMPLES >= 100_000


@pytest.mark.parametrize("bad", [0, 0.05, 4000, -1, float("nan"), "60", True, None])
def test_window_out_of_range_is_refused_naming_the_range(bad):
    rec = TraceRecorder(window_s=30)
    with pytest.raises(gw.GrassValueError, match=r"window_s .* in \[0.1, 3600\]"):
        rec.window_s = bad
    assert rec.window_s == 30.0
    with pytest.raises(ValueError, match="window_s"):
        TraceRecorder(window_s=bad)


@pytest.mark.parametrize("ext", [".csv", ".npz"])
def test_save_and_load_round_trip(tmp_path, ext):
    rng = np.random.default_rng(2)
    rec = TraceRecorder(window_s=12.5)
    rec.record(_sample(0.1, 12, [5, 9], rng))
    rec.record(_sample(0.2, 24, [9], rng, kept={"orientation": 90, "frustum": None}))
    path = rec.save(tmp_path / f"traces{ext}")
    assert path.endswith(ext)
    got, want = load_traces(path), rec.traces()
    assert set(got) == set(want)  # every field comes back
    assert got["window_s"] == want["window_s"] == 12.5
    for key in ("t", "step", "ids", "v0", "v2", "tip_offset", "bend_deg", "collision"):
        np.testing.assert_allclose(got[key], want[key], rtol=0, atol=0, equal_nan=True, err_msg=key)
    for group in ("kept", "drawn", "frame_ms", "force"):
        for name in want[group]:
            np.testing.assert_allclose(got[group][name], want[group][name], rtol=0, atol=0, equal_nan=True,
                                       err_msg=f"{group} {name}")
    assert np.isnan(got["kept"]["frustum"][1]) and got["kept"]["orientation"][1] == 90


def test_bad_paths_are_refused(tmp_path):
    rec = TraceRecorder()
    with pytest.raises(gw.GrassValueError, match=r"path must end in \.csv or \.npz"):
        rec.save(tmp_path / "traces.json")
    with pytest.raises(gw.MissingFileError, match="does not exist"):
        rec.save(tmp_path / "no" / "traces.csv")
    with pytest.raises(gw.GrassTypeError, match="path"):
        rec.save(42)
    with pytest.raises(gw.MissingFileError, match="no traces file"):
        load_traces(tmp_path / "missing.npz")


def _good_files(tmp_path):
    rng = np.random.default_rng(4)
    rec = TraceRecorder()
    for k in range(1, 4):
        rec.record(_sample(0.1 * k, 12 * k, [5, 9], rng))
    return {ext: Path(rec.save(tmp_path / f"good{ext}")) for ext in (".csv", ".npz")}


def _broken(tmp_path, good):
    """(name, bytes, what the error says) for files that are not traces."""
    csv_text = good[".csv"].read_bytes()
    npz = good[".npz"].read_bytes()
    header = csv_text.split(b"\n")[0]
    return [
        ("empty.csv", b"", "empty"),
        ("empty.npz", b"", "empty"),
        ("truncated.csv", csv_text[: len(csv_text) * 2 // 3], "line .* cells"),
        ("truncated.npz", npz[: len(npz) // 2], "not a traces file"),
        ("garbage.csv", bytes(range(256)) * 4, "not a traces file"),
        ("garbage.npz", b"PK\x03\x04" + bytes(range(200)), "not a traces file"),
        ("latin1.csv", "t,step\n0.1,caf\xe9\n".encode("latin-1"), "not a traces file"),
        ("words.csv", header + b"\n" + b",".join([b"abc"] * len(header.split(b","))) + b"\n", "'abc' is not a number"),
        ("other.csv", b"a,b,c\n1,2,3\n", "no 't' column"),
        ("columns.csv", b"t,step,v2x_3\n0.1,1,0.5\n", "no column 'v0x_3'"),
        ("text.npz", b"hello, world", "not a traces file"),
        ("pickled.npz", _pickled_npz(), "pickled Python objects, which are never loaded"),
    ]


def _pickled_npz() -> bytes:
    import io

    buf = io.BytesIO()
    np.savez(buf, t=np.array([{"run": "code"}], dtype=object), step=np.arange(1))
    return buf.getvalue()


def test_a_broken_traces_file_is_named_with_what_is_wrong(tmp_path):
    good = _good_files(tmp_path)
    for name, data, says in _broken(tmp_path, good):
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(gw.TraceFileError, match=re.escape(repr(str(path))) + ".*" + says) as err:
            load_traces(path)
        assert isinstance(err.value, ValueError) and isinstance(err.value, gw.GrassError)
        assert "unsafe" not in str(err.value)  # never advice to unpickle a file
    for ext, path in good.items():  # the good ones still read
        assert len(load_traces(path)["t"]) == 3


def test_chart_series_colours_thinning_and_kinds():
    rng = np.random.default_rng(3)
    rec = TraceRecorder()
    for step in range(1, 1001):
        rec.record(_sample(step / 120, step, [4, 8] if step < 900 else [8], rng))
    colors = ["#111111", "#222222", "#333333"]
    d = rec.chart_series("tip", colors, max_points=100)
    assert len(d["x"]) <= 101 and d["x"][-1] == pytest.approx(1000 / 120)
    by_label = {s["label"]: s for s in d["series"]}
    # blade 8 is the only one inspected now: the first colour (as the panel's inspector line); 4 the next
    assert by_label["blade 8"]["color"] == "#111111" and by_label["blade 4"]["color"] == "#222222"
    assert by_label["blade 4"]["values"][-1] is None  # no longer inspected: a gap
    tr = rec.traces()
    assert by_label["blade 8"]["values"][-1] == pytest.approx(100 * tr["tip_offset"][-1, 1])
    for kind in CHART_KINDS:
        assert rec.chart_series(kind, colors)["series"]
    assert [s["label"] for s in rec.chart_series("culling", colors)["series"]] == [f"kept after {t}" for t in CULL_TESTS]
    with pytest.raises(gw.GrassValueError, match="chart must be None or one of 'tip', 'bend', 'culling', 'frame'"):
        rec.chart_series("pie", colors)


def test_cull_counter_against_the_reference_on_the_rest_pose():
    blades = gw.Blades.on_plane(3000, seed=4)
    params = gw.GrassParams(cull_occlusion=False)
    cam = {"position": [0.0, 4.0, 14.0], "target": [0.0, 0.0, 0.0], "fov_deg": 50.0}
    counter = CullCounter(blades, params)
    kept = counter.kept(cam, (0.1, 200.0), (320, 240), visible=700, occluded=50)
    vp = camera_view_proj(cam["position"], cam["target"], 50.0, 0.1, 200.0, 320 / 240)
    state = blades.rest_state()
    # independent: each test alone, combined in the paper's order
    t1 = reference.width_direction(state["up"], state["orientation"])
    o = reference.orientation_cull(state["v0"], t1, np.array(cam["position"]), params.cull_orientation_threshold)
    f = reference.frustum_cull(state["v0"], state["v1"], state["v2"], vp, params.cull_frustum_tolerance)
    assert kept["orientation"] == int((~o).sum()) < 3000
    assert kept["frustum"] == int((~o & ~f).sum()) < kept["orientation"]
    assert kept["occlusion"] == 700 and kept["distance"] == 700  # occlusion culling off: occluded ignored
    params.cull_occlusion = True
    assert counter.kept(cam, (0.1, 200.0), (320, 240), visible=700, occluded=50)["distance"] == 750
    params.cull_orientation = params.cull_frustum = False
    counter.set_blades(blades)
    kept = counter.kept(cam, (0.1, 200.0), (320, 240))
    assert kept["orientation"] == kept["frustum"] == 3000 and kept["distance"] is None


def test_cull_counter_recounts_in_the_background_when_the_camera_moves():
    blades = gw.Blades.on_plane(2000, seed=5)
    clock = TickingWall()  # a clock that moves only when told
    counter = CullCounter(blades, gw.GrassParams(cull_occlusion=False), clock=clock)
    near = {"position": [0.0, 4.0, 14.0], "target": [0.0, 0.0, 0.0], "fov_deg": 50.0}
    away = {"position": [0.0, 4.0, -14.0], "target": [0.0, 0.0, -40.0], "fov_deg": 50.0}  # looking off the field
    first = counter.kept(near, (0.1, 200.0), (320, 240))  # the first count is done at once
    assert first["frustum"] > 0
    clock.advance(RECOUNT_INTERVAL_S)
    # a moved camera starts a recount on a worker thread, answering with the last counts meanwhile
    counter.kept(away, (0.1, 200.0), (320, 240))
    counter.wait()
    assert counter.kept(away, (0.1, 200.0), (320, 240))["frustum"] < first["frustum"] // 4


def test_stats_freshness_says_how_old_the_stats_are():
    """Issue 37, item 4 (the rule both engines' stats use, core.engine_inputs.stats_freshness)."""
    from grasswidget.core.engine_inputs import WAITING_AFTER_S, stats_freshness

    none_yet = stats_freshness(100.0, None, playing=True)
    assert none_yet == {"frame_age_s": None, "at_rest": False, "stale": False, "waiting": False}
    fresh = stats_freshness(100.0, 99.8, playing=True)
    assert fresh["frame_age_s"] == pytest.approx(0.2) and not fresh["stale"] and not fresh["waiting"]
    # playing, the newest frame older than a stats interval: stale; waiting only past WAITING_AFTER_S
    late = stats_freshness(100.0, 99.0, playing=True)
    assert late["stale"] and not late["waiting"]
    assert stats_freshness(100.0, 100.0 - WAITING_AFTER_S - 0.1, playing=True)["waiting"]
    # paused: an old frame is still the picture, unless a change has waited longer than an interval
    assert not stats_freshness(100.0, 40.0, playing=False)["stale"]
    assert not stats_freshness(100.0, 40.0, playing=False, changed_t=99.9)["stale"]
    assert stats_freshness(100.0, 40.0, playing=False, changed_t=99.0)["stale"]
    # at rest: stale whatever else, never "waiting" (nothing is asked for)
    rest = stats_freshness(100.0, 99.9, playing=True, at_rest=True)
    assert rest["at_rest"] and rest["stale"] and not rest["waiting"]
    # the interval is the view's (a chart asks for 0.2 s)
    assert stats_freshness(100.0, 99.7, playing=True, interval_s=0.2)["stale"]
    assert not stats_freshness(100.0, 99.7, playing=True, interval_s=0.5)["stale"]
