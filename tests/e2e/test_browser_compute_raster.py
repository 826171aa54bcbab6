"""The compute rasterizer of thin blades in the browser engine, in a real JupyterLab + Chromium (WebGPU on SwiftShader).

The browser engine runs the kernel engine's compute rasterizer of thin blades (the same
``raster.wgsl`` and ``raster_resolve.wgsl``, composed by :mod:`grasswidget.browser.browser_wgsl`):

* its picture with ``params.compute_raster`` on against off (same state and camera): no holes
  (per row, never less grass), mean difference of 4 x 4-pixel block means small;
* its picture with it on against the kernel engine's (a GrassScene on lavapipe) with it on;
* the blades it drew in compute (its stats' ``rastered``) against the kernel engine's count
  for the same blades, parameters, camera and frame size, and the teaching colour
  (colour by LOD: the compute-drawn blades flat in ``COMPUTE_RASTER_COLOR``).

Pictures land in ``$GW_ARTIFACTS_DIR`` (else the Lab root's ``artifacts`` folder):
``compute_raster_browser_on_off.png`` (on left, off right) and
``compute_raster_engines.png`` (kernel left, browser right).
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .polling import poll
from .test_engines_alike import _artifacts, _run

pytestmark = pytest.mark.browser

N_BLADES = 1 << 14
SIZE = (320, 180)



def _grass(img):
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (g > r + 8) & (g > b + 8)


def _block_difference(a, b, block=4):
    """Mean |a - b| (0..255) of the pictures' 4 x 4-pixel block means (the look; pixel by pixel
    two renders of sub-pixel grass differ in which blade wins each pixel)."""
    h, w = a.shape[0] // block * block, a.shape[1] // block * block

    def blocks(x):
        return x[:h, :w, :3].astype(float).reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))

    return float(np.abs(blocks(a) - blocks(b)).mean())


def _steady_stats(page, keys, compute_on):
    """The widget's stats once they come from a frame drawn with the compute rasterizer
    ``compute_on`` (some blades in compute when on, none when off: the stats of frames
    drawn before the switch reached the page keep coming while the page compiles the
    rasterizer's pipelines, and three of those agree too) and three messages in a row
    agree (paused, still camera). A compute path that never draws a blade times out here."""
    seen = []

    def steady():
        s = kernel_eval(page, "{k: m.stats.get(k) for k in %r}" % (keys,))
        if s["visible"] is None or ((s["rastered"] or 0) > 0) != compute_on:
            seen.clear()
            return False, s
        seen.append(s)
        return len(seen) >= 3 and all(x == s for x in seen[-3:]), s

    return poll(steady, "steady browser stats", 120, 1.0, page=page)


def _pictures_and_counts(page, out_dir):
    kernel_execute(page, "m.pause()\nm.reset_blades()\nm.step(30)\nm.params.cull_occlusion = False", timeout=60)
    found = {}
    for mode in (True, False):
        kernel_execute(page, f"m.params.compute_raster = {mode}")
        stats = _steady_stats(page, ["visible", "rastered", "frame_size", "step_count"], compute_on=mode)
        found[mode] = stats
        kernel_execute(page, f"m.save_png({os.path.join(out_dir, f'raster_browser_{int(mode)}.png')!r}, size={SIZE})",
                       timeout=60)
    kernel_execute(page, "m.params.compute_raster = True\nm.params.color_by = 'lod'")
    kernel_execute(page, f"m.save_png({os.path.join(out_dir, 'raster_browser_lod.png')!r}, size={SIZE})", timeout=60)
    kernel_execute(page, "m.params.color_by = 'natural'")
    w, h = found[True]["frame_size"]
    assert (w, h) == SIZE  # pixel_ratio 1: the saved pictures are the frames counted
    out = kernel_execute(page, f"""
import json
from grasswidget.gpu.scene import GrassScene
p = m.params.copy()
p.compute_raster = True
p.cull_occlusion = False
scene = GrassScene.preset('meadow', blades=m.view.engine_widget.blades, size=({w}, {h}), params=p)
scene.step(30)
cam = m.camera_state
scene.look(cam['position'], cam['target'], cam['fov_deg'])
scene.render()
kernel = scene.drawn_counts()
scene.save_png({os.path.join(out_dir, 'raster_kernel_1.png')!r})
scene.params.compute_raster = False
scene.save_png({os.path.join(out_dir, 'raster_kernel_0.png')!r})
scene.release()
print('KERNEL' + json.dumps(kernel))
""", timeout=240)
    return found, json.loads(out.stdout.split("KERNEL")[1].strip())


def test_browser_compute_raster(webgpu_browser, lab_server, browser_root):
    """The browser's compute rasterizer: picture on vs off, against the kernel's, and its counts."""
    import imageio.v3 as iio
    from grasswidget.core.teaching import COMPUTE_RASTER_COLOR, hex_to_rgb

    page = webgpu_browser.page
    out_dir = _artifacts(browser_root)
    found = {}

    def check():
        status = wait_for_kernel(page, "m.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=60)
        assert status["state"] == "ok", status
        found["stats"], found["kernel"] = _pictures_and_counts(page, out_dir)

    _run(page, lab_server, browser_root, "compute_raster_browser.ipynb", [
        "import grasswidget as gw\n"
        # the dense square meadow (horizon=False), not the sparser field to the horizon
        f"from grasswidget.core.presets import preset_field\n"
        f"m = gw.GrassWidget(preset_field('meadow', {N_BLADES}, horizon=False)[0], preset='meadow', backend='browser', "
        f"size={SIZE}, pixel_ratio=1)\nm",
    ], check, webgpu_browser)

    read = lambda name: iio.imread(os.path.join(out_dir, name))[..., :3].astype(int)  # noqa: E731
    on, off, kernel, kernel_off, lod = (read(f"raster_{n}.png")
                                        for n in ("browser_1", "browser_0", "kernel_1", "kernel_0", "browser_lod"))
    gap = np.full((SIZE[1], 4, 3), 255)
    iio.imwrite(os.path.join(out_dir, "compute_raster_browser_on_off.png"),
                np.concatenate([on, gap, off], axis=1).astype(np.uint8))
    iio.imwrite(os.path.join(out_dir, "compute_raster_engines.png"),
                np.concatenate([kernel, gap, on], axis=1).astype(np.uint8))
    stats_on, stats_off, counts = found["stats"][True], found["stats"][False], found["kernel"]
    on_off = _block_difference(on, off)
    kernel_on_off = _block_difference(kernel, kernel_off)
    engines = float(np.abs(on - kernel).mean())
    white = (lod >= 250).all(axis=2).mean()
    print(f"\n[compute raster, browser] meadow {N_BLADES} at {stats_on['frame_size']}: on: {stats_on['visible']} "
          f"drawn, {stats_on['rastered']} in compute; off: {stats_off['visible']} drawn, {stats_off['rastered']} in "
          f"compute; kernel: {counts['hardware']} ribbons + {counts['compute']} compute; picture on vs off: block "
          f"difference {on_off:.2f}/255 (kernel's: {kernel_on_off:.2f}), grass {_grass(on).mean():.3f} vs {_grass(off).mean():.3f}; browser vs "
          f"kernel (on): mean |diff| {engines:.2f}/255; colour by LOD: {white:.2%} in the compute colour")
    # The compute path draws many of the meadow's far blades, and nothing while off.
    assert stats_on["rastered"] > 0.3 * stats_on["visible"]
    assert stats_off["rastered"] == 0
    # Both paths together draw the blades drawn as ribbons while it is off.
    assert stats_on["visible"] == stats_off["visible"]
    # Same blades, camera and frame size: the kernel lists the same thin blades (up to float
    # rounding at the width threshold and the culling tests' edges).
    assert abs(stats_on["rastered"] - counts["compute"]) <= max(5, 0.002 * counts["compute"])
    assert abs(stats_on["visible"] - counts["hardware"] - counts["compute"]) <= max(5, 0.002 * stats_on["visible"])
    # The look: mean difference small (as the kernel's own, on vs off, in this view), no holes (per
    # row, never less grass), a little more grass at most (the LOD ribbons' 1-segment blades are
    # narrower at the top), as the kernel's test.
    assert on_off < 4.5
    assert on_off < kernel_on_off + 0.5
    rows_on, rows_off = _grass(on).mean(axis=1), _grass(off).mean(axis=1)
    assert np.all(rows_on >= rows_off - 0.15)
    assert -0.01 < _grass(on).mean() - _grass(off).mean() < 0.08
    assert _grass(on).mean() > 0.2
    # The two engines' pictures with it on (as test_engines_alike with it off).
    assert engines < 6.0
    # Teaching colour: the compute-drawn blades in COMPUTE_RASTER_COLOR (white), none with it off.
    assert tuple(hex_to_rgb(COMPUTE_RASTER_COLOR)) == (255, 255, 255)
    assert white > 0.01
    assert (off >= 250).all(axis=2).mean() < 0.2 * white
