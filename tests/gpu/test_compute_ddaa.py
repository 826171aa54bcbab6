"""pygfx's DDAA anti-aliasing computed in a compute pass (grasswidget/gpu/compute_ddaa.py) gives
pygfx's picture, and sits in the renderer like pygfx's own pass.

The pictures: one meadow frame (1,024 blades, 160x120 and, with the same pass, 200x100: its own
texture follows the size) rendered through pygfx's fragment DDAA, through the compute one and
with no anti-aliasing. Measured on lavapipe (320x240): 0.4 % of pixels one level of 255 apart (the
colour goes through a half float between the compute and the copy) and 0.02 % further, up to 9
levels: DDAA's thresholds flip where a texel coordinate differs in its last bit between the
rasterizer's interpolation and the shader's computation (on the H100 at 1920x1080, 0.22 % and
0.004 %, the flips up to 88 levels: benchmarks/results/compute_ddaa_pixels-h100-2026-11-26.json). DDAA itself changes
3-5 % of these pixels, so a pass that did nothing, or anti-aliased elsewhere, fails.
"""

from __future__ import annotations

import numpy as np
import pygfx as gfx
import pytest
from pygfx.renderers.wgpu import DDAAPass as PygfxDDAAPass
from rendercanvas.offscreen import RenderCanvas

from grasswidget.gpu.compute_ddaa import DDAAPass, use_compute_ddaa
from grasswidget.gpu.scene import GrassScene


@pytest.fixture(scope="module")
def stepped_meadow():
    scene = GrassScene.preset("meadow", blades=1024, size=(160, 120))
    scene.field.step(3)
    yield scene
    scene.release()


def _render(scene, size, passes):
    canvas = RenderCanvas(size=size, pixel_ratio=1)
    renderer = gfx.WgpuRenderer(canvas, pixel_ratio=1, ppaa="none", enable_events=False)
    renderer.effect_passes = passes
    canvas.request_draw(lambda: scene.draw_into(renderer))
    try:
        return np.asarray(canvas.draw())[..., :3].astype(np.int16)
    finally:
        canvas.close()


def test_compute_ddaa_gives_pygfx_ddaa_picture(stepped_meadow):
    ours = DDAAPass()
    for size in ((160, 120), (200, 100)):  # the same pass at a second size: its texture follows
        plain = _render(stepped_meadow, size, [])
        fragment = _render(stepped_meadow, size, [PygfxDDAAPass()])
        computed = _render(stepped_meadow, size, [ours])
        assert computed.shape == (size[1], size[0], 3)
        aa = np.abs(fragment - plain).max(axis=-1)
        assert (aa > 0).mean() > 0.01 and aa.max() >= 8, "DDAA changed too little for this test to mean anything"
        d = np.abs(computed - fragment).max(axis=-1)
        assert np.abs(computed - fragment).mean() < 0.05, size
        assert (d > 1).mean() < 0.001, (size, np.bincount(d.ravel()))  # DDAA's branches flipped
        assert (d == 1).mean() < 0.02, size  # the half float's rounding
        assert np.abs(computed - plain).max(axis=-1).mean() > 0.5 * aa.mean()  # it anti-aliased


def test_replaces_only_pygfx_ddaa_and_reads_as_ddaa():
    target = gfx.Texture(dim=2, size=(32, 32, 1), format="rgba8unorm")
    renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa="ddaa", enable_events=False)
    noise = gfx.renderers.wgpu.NoisePass(0.1)
    renderer.effect_passes = [noise, PygfxDDAAPass(max_edge_iters=3)]
    assert use_compute_ddaa(renderer)
    passes = renderer.effect_passes
    assert passes[0] is noise and type(passes[1]) is DDAAPass and passes[1].max_edge_iters == 3
    assert renderer.ppaa == "ddaa"
    assert not use_compute_ddaa(renderer)  # nothing left to replace
    saved = renderer.ppaa  # what the teaching views do: save, switch off, restore
    renderer.ppaa = "none"
    assert renderer.effect_passes == (noise,)
    renderer.ppaa = saved
    assert renderer.ppaa == "ddaa"
