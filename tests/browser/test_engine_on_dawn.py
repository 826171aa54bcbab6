"""The browser engine's module run on Dawn (Chrome's WebGPU, dawn.node) in node, without a browser:
benchmarks/browser_engine_dawn.py + benchmarks/dawn/run_engine.mjs, once, small, on SwiftShader
(Debian's chromium ships its Vulkan driver; Dawn refuses Mesa 22's lavapipe).

The engine draws the meadow preset as a user gets it (the state of ``GrassWidget(4096, preset="meadow",
backend="browser")``: the field to the horizon, the preset's camera and parameters, the sunlight's
default for SwiftShader), plays, is timed pass by pass, and its frame of a stepped state matches the
kernel engine's picture of the same state (lavapipe) and its count of blades drawn the kernel's; the
metric is recomputed here in NumPy from the frame the script saved.
"""

from __future__ import annotations

import importlib.util
import json
import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]

# About a minute on this 2-core machine (SwiftShader compiles the engine's pipelines in ~20 s).
pytestmark = [pytest.mark.slow]

BLADES, SIZE = 4096, (160, 120)


def _bench():
    spec = importlib.util.spec_from_file_location("browser_engine_dawn", ROOT / "benchmarks" / "browser_engine_dawn.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_browser_engine_on_dawn_draws_the_kernel_engines_picture(tmp_path):
    bench = _bench()
    if not os.path.exists(bench.SWIFTSHADER_ICD):
        pytest.fail(f"{bench.SWIFTSHADER_ICD} is missing: ./run.sh test installs Debian's chromium, which ships it")
    dawn = Path(os.environ["GW_DAWN_DIR"]) if os.environ.get("GW_DAWN_DIR") else bench.fetch_dawn()
    manifest = bench.prepare(tmp_path / "states", [BLADES], SIZE)
    out = tmp_path / "out" / "result.json"
    result = bench.run_node(manifest, out, dawn, seconds=1.0, warmup=0.5, profile_frames=2,
                            env=bench.swiftshader_env(), timeout=600)
    assert json.loads(out.read_text()) == result
    assert result["adapter"]["architecture"] == "swiftshader", result["adapter"]
    # the meadow as a user gets it: GrassWidget(BLADES, preset="meadow", backend="browser") on this adapter
    scene = json.loads(manifest.read_text())["cases"][0]["scene"]
    from grasswidget.core.presets import preset_field

    view = preset_field("meadow", BLADES)[2]
    assert scene["horizon"] is True and scene["shadows"] is False, scene  # to the horizon; a CPU's sunlight default
    assert scene["camera"]["position"] == pytest.approx(list(view["position"])), scene
    assert scene["camera"]["far"] == view["far"] and scene["camera"]["fov_deg"] == view["fov_deg"], scene
    case = result["cases"][0]
    print(f"\n[dawn] {case['fps']} frames/s, GPU {case['gpu_ms_per_frame']} ms/frame {case['gpu_ms_per_pass']}, "
          f"picture {case['picture']}")
    assert case["errors"] == [] and case["fps"] > 0
    import imageio.v3 as iio

    w, h = SIZE
    frame = np.frombuffer(Path(case["frame_file"]).read_bytes(), np.uint8).reshape(h, w, 4)
    kernel_file = manifest.parent / json.loads(manifest.read_text())["cases"][0]["kernel_picture"]
    kernel = np.frombuffer(kernel_file.read_bytes(), np.uint8).reshape(h, w, 4)
    iio.imwrite(tmp_path / "dawn_vs_kernel.png", np.concatenate([kernel, frame], axis=1))
    print(f"[dawn] kernel | dawn: {tmp_path / 'dawn_vs_kernel.png'}")
    # the engine's own count of blades drawn in the compared state (its counters read back after the steps,
    # paused) against the kernel engine's count of that state: the same culling rules, a few blades apart
    # where the engines round differently. (The count while playing is of another state: the wind moved the
    # blades for as long as the engine played, and it drifted 5 % from the kernel's in one run of 11-29.)
    kernel_visible = json.loads(manifest.read_text())["cases"][0]["kernel_visible"]
    stepped = case["visible_stepped"]
    print(f"[dawn] blades drawn: engine {sum(stepped)} ({stepped}), while playing {case['visible_last']}, "
          f"kernel {kernel_visible}")
    assert kernel_visible > 0 and abs(sum(stepped) - kernel_visible) <= 0.05 * kernel_visible
    if result["adapter"]["timestamp_query"]:  # every pass timed: simulation, culling and the draws
        kinds = " ".join(case["gpu_ms_per_pass"])
        assert "simulate" in kinds and "cull" in kinds and "render: blade_render" in kinds, kinds
        assert case["gpu_ms_per_frame"] == pytest.approx(sum(case["gpu_ms_per_pass"].values()), rel=1e-3)
    # The picture: the engine's frame of (rest pose + STEPS steps, preset camera) against the kernel's.
    ours = bench.frame_difference(frame, kernel)
    assert ours["mean_abs"] == pytest.approx(case["picture"]["mean_abs"], rel=1e-6)
    assert ours["share_over_40"] == pytest.approx(case["picture"]["share_over_40"], rel=1e-6)
    assert case["picture"]["pass"]
    assert ours["mean_abs"] <= bench.TOLERANCE_MEAN and ours["share_over_40"] <= bench.TOLERANCE_SHARE
    rgb = frame[..., :3].astype(int)
    grass = ((rgb[..., 1] > rgb[..., 0] + 8) & (rgb[..., 1] > rgb[..., 2] + 8)).mean()
    sky = ((rgb[..., 2] > rgb[..., 0] + 10) & (rgb[..., 2] >= rgb[..., 1])).mean()
    soil = ((rgb[..., 0] > rgb[..., 2] + 8) & (rgb.sum(axis=2) < 250)).mean()
    # The meadow to the horizon at this count: a sparse near disc (blades on soil), the far grass and the
    # grass-coloured ground beyond it, under a sky.
    assert grass > 0.005 and soil > 0.1 and sky > 0.2, (grass, soil, sky)
    # A different state is a different picture: the metric can fail.
    assert bench.frame_difference(frame, kernel[::-1])["mean_abs"] > 4 * max(ours["mean_abs"], 1.0)


def test_matrix_through_dawn_auto_decided_by_the_python_widget(tmp_path):
    """browser_engine_dawn.py --matrix, one small row on SwiftShader: the Python widget (its comm over
    node's stdin / stdout) runs the "auto" trial from the engine's frame times and decides; the engine
    executes the decision (the switches of the frames it counted are the values Python sent); every
    setting's window has frames and counts that agree with each other."""
    bench = _bench()
    if not os.path.exists(bench.SWIFTSHADER_ICD):
        pytest.fail(f"{bench.SWIFTSHADER_ICD} is missing: ./run.sh test installs Debian's chromium, which ships it")
    from benchmarks import browser_matrix
    from benchmarks.dawn_page import DawnPage

    dawn = Path(os.environ["GW_DAWN_DIR"]) if os.environ.get("GW_DAWN_DIR") else bench.fetch_dawn()
    seen = {}

    class RecordingPage(DawnPage):  # what the widget holds when the row closes it
        def hide(self):
            switches = self.widget.view.engine_widget.auto_switches
            seen.update(trial_frames=switches.state.trial_frames_run, values=dict(switches.values))
            super().hide()

    n = 1024
    # the cis565 view at 1024 blades: its near grass hides some of the far (about 15 % here), and a few far
    # blades are thin enough for the compute rasterizer, so both switches are decided by timing frames
    rows = [("cis565", n, (160, 120))]
    with RecordingPage(dawn, env=bench.swiftshader_env()) as page:
        assert page.ready["adapter"]["architecture"] == "swiftshader", page.ready
        matrix = browser_matrix.run_matrix(page, rows, rounds=1, window_s=0.3)
        assert page.process.poll() is None  # node still serving after the widget closed
    row = matrix["rows"][0]
    print(f"\n[dawn matrix] {row['median_frames_per_s']}, decided {row['decided']}, trial {row['trial_s']} s")
    # "auto" decided through the harness, by the widget's own trial of the engine's frames
    assert set(row["decided"]) == {"cull_occlusion", "compute_raster"}
    assert all(t.startswith(("auto (on:", "auto (off:")) for t in row["decided"].values()), row["decided"]
    assert seen["trial_frames"] > 0, "no frame time of the engine reached the trial"
    assert row["decided_after_run"] == row["decided"]  # forcing and going back to "auto" keeps the decision
    decided = [row["decided"][s].startswith("auto (on:") for s in ("cull_occlusion", "compute_raster")]
    assert [seen["values"]["cull_occlusion"], seen["values"]["compute_raster"]] == decided
    # the engine executed what Python sent: the counted frames of the defaults' window ran the decision
    assert row["counts"]["defaults"][0]["switches"] == decided
    for name, occlusion, raster in browser_matrix.MATRIX_SETTINGS:
        fps, counts = row["frames_per_s"][name], row["counts"][name][0]
        expected = decided if name == "defaults" else [occlusion, raster]
        assert len(fps) == 1 and fps[0] > 0, (name, fps)
        assert counts["switches"] == expected, (name, counts)
        assert 0 < counts["drawn"] <= n, (name, counts)
        assert (counts["occluded"] is None) == (not expected[0]), (name, counts)
        assert expected[1] or counts["rastered"] == 0, (name, counts)
    # occlusion removes blades from those the frustum keeps: drawn + occluded with it on is what is
    # drawn with it off (the same camera; the grass sways, so within a few %)
    on, off = row["counts"]["occl on, cr off"][0], row["counts"]["occl off, cr off"][0]
    assert on["occluded"] > 0.05 * off["drawn"], (on, off)
    assert abs(on["drawn"] + on["occluded"] - off["drawn"]) <= 0.03 * off["drawn"], (on, off)
    assert row["best_fixed"] in row["frames_per_s"] and row["defaults_over_best"] > 0
