"""The browser engine's module run on Dawn (Chrome's WebGPU, dawn.node) in node, without a browser:
benchmarks/browser_engine_dawn.py + benchmarks/dawn/run_engine.mjs, once, small, on SwiftShader
(Debian's chromium ships its Vulkan driver; Dawn refuses Mesa 22's lavapipe).

The engine draws the meadow from the state Python sends, plays, is timed pass by pass, and its frame
of a stepped state matches the kernel engine's picture of the same state (lavapipe); the metric is
recomputed here in NumPy from the frame the script saved.
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

BLADES, SIZE = 1024, (160, 120)


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
    case = result["cases"][0]
    print(f"\n[dawn] {case['fps']} frames/s, GPU {case['gpu_ms_per_frame']} ms/frame {case['gpu_ms_per_pass']}, "
          f"picture {case['picture']}")
    assert case["errors"] == [] and case["fps"] > 0
    assert sum(case["visible_last"]) > 0.2 * BLADES  # the engine's own count of blades drawn
    if result["adapter"]["timestamp_query"]:  # every pass timed: simulation, culling and the draws
        kinds = " ".join(case["gpu_ms_per_pass"])
        assert "simulate" in kinds and "cull" in kinds and "render: blade_render" in kinds, kinds
        assert case["gpu_ms_per_frame"] == pytest.approx(sum(case["gpu_ms_per_pass"].values()), rel=1e-3)
    # The picture: the engine's frame of (rest pose + STEPS steps, preset camera) against the kernel's.
    w, h = SIZE
    frame = np.frombuffer(Path(case["frame_file"]).read_bytes(), np.uint8).reshape(h, w, 4)
    kernel_file = manifest.parent / json.loads(manifest.read_text())["cases"][0]["kernel_picture"]
    kernel = np.frombuffer(kernel_file.read_bytes(), np.uint8).reshape(h, w, 4)
    ours = bench.frame_difference(frame, kernel)
    assert ours["mean_abs"] == pytest.approx(case["picture"]["mean_abs"], rel=1e-6)
    assert ours["share_over_40"] == pytest.approx(case["picture"]["share_over_40"], rel=1e-6)
    assert case["picture"]["pass"]
    assert ours["mean_abs"] <= bench.TOLERANCE_MEAN and ours["share_over_40"] <= bench.TOLERANCE_SHARE
    rgb = frame[..., :3].astype(int)
    grass = ((rgb[..., 1] > rgb[..., 0] + 8) & (rgb[..., 1] > rgb[..., 2] + 8)).mean()
    sky = ((rgb[..., 2] > rgb[..., 0] + 10) & (rgb[..., 2] >= rgb[..., 1])).mean()
    soil = ((rgb[..., 0] > rgb[..., 2] + 8) & (rgb.sum(axis=2) < 250)).mean()
    # The meadow preset's field at this count is sparse (1024 blades on 15 x 15 m): blades on soil under a sky.
    assert grass > 0.005 and soil > 0.1 and sky > 0.2, (grass, soil, sky)
    # A different state is a different picture: the metric can fail.
    assert bench.frame_difference(frame, kernel[::-1])["mean_abs"] > 4 * max(ours["mean_abs"], 1.0)
    import imageio.v3 as iio

    iio.imwrite(tmp_path / "dawn_vs_kernel.png", np.concatenate([kernel, frame], axis=1))
    print(f"[dawn] kernel | dawn: {tmp_path / 'dawn_vs_kernel.png'}")
