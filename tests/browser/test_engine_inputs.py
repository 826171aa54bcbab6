"""What a frame needs besides GPU execution is decided once, in Python.

* The uniform values: the kernel engine's ``u_sim`` / ``u_cull`` buffers (written by
  GrassField / Simulation) hold byte for byte what the browser engine is sent
  (``browser.uniforms``), both from ``engine_inputs``.
* The clock's rules and the orbit limits: engine.js's ``SimClock`` and ``clampOrbit``
  (run here with Node.js, the ES module as shipped) give what ``grasswidget.views.clock.SimClock``
  and ``grasswidget.core.orbit_limits.clamp_orbit`` give, frame by frame and pose by pose.
* The scene style: GrassScene's sky and ground are the ones the browser is sent.
"""

from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

import grasswidget as gw
from conftest import node_executable
from grasswidget.core import engine_inputs
from grasswidget.browser import uniforms
from grasswidget.browser.engine_widget import HERE as BROWSER_DIR
from grasswidget.views.clock import MAX_STEPS_PER_FRAME, SimClock
from grasswidget.core.orbit_limits import OrbitLimits, clamp_orbit
from grasswidget.core.uniform_layouts import CULL_LAYOUT, SIM_LAYOUT, pack


def _params():
    return gw.GrassParams(wind_strength=7.5, wind_direction=33.0, wind_field="vortex", dt=0.01, gravity_mode="point",
                          gravity_center=(1.0, -3.0, 2.0), cull_distance_max=37.0, color_by="lod", lod=False)


def test_kernel_buffers_hold_the_bytes_the_browser_is_sent():
    from grasswidget.gpu.field import GrassField

    params = _params()
    field = GrassField(gw.Blades.on_plane(300, seed=3), params=params)
    try:
        field.colliders.append(gw.SphereCollider(center=(0.5, 0.2, -1.0), radius=0.4))
        field.simulation.write_uniform(7, 0.25)
        kernel_sim = field.simulation.uniform_buffer.data.tobytes()
        browser_sim = bytearray(uniforms.sim_uniform(params, field.count, field.colliders))
        # the browser writes steps and time0 itself, per dispatch, at these offsets
        off = uniforms.offsets(SIM_LAYOUT)
        browser_sim[off["steps"][0]: off["steps"][0] + 4] = np.int32(7).tobytes()
        browser_sim[off["time0"][0]: off["time0"][0] + 4] = np.float32(0.25).tobytes()
        assert kernel_sim == bytes(browser_sim)
        # The browser draws every frame in occlusion culling's two phases (occlusion_phase 1 while
        # cull_occlusion is on); the kernel arms its first phase per render (render_frame). The
        # compute rasterizer's material values: the kernel writes them when it sets up a render.
        field.prepare_compute_raster((640, 480))
        assert field.cull_uniform_buffer.data.tobytes() != uniforms.cull_uniform(params, field.count)
        field.occlusion.arm(1)
        assert field.cull_uniform_buffer.data.tobytes() == uniforms.cull_uniform(params, field.count)
        # With the compute rasterizer on, the same bytes but the render size, which the browser
        # writes for each view (shaders.compute_raster's width_offset and height_offset).
        params.compute_raster = True
        field.prepare_compute_raster((640, 480))
        browser_cull = bytearray(uniforms.cull_uniform(params, field.count))
        at = uniforms.offsets(CULL_LAYOUT)
        assert browser_cull[at["compute_raster"][0]: at["compute_raster"][0] + 4] == np.int32(1).tobytes()
        browser_cull[at["raster_width"][0]: at["raster_width"][0] + 4] = np.float32(640).tobytes()
        browser_cull[at["raster_height"][0]: at["raster_height"][0] + 4] = np.float32(480).tobytes()
        assert field.cull_uniform_buffer.data.tobytes() == bytes(browser_cull)
        params.compute_raster = False
        field.prepare_compute_raster((640, 480))
        off = uniforms.offsets(CULL_LAYOUT)["occlusion_phase"][0]
        params.cull_occlusion = False
        assert uniforms.cull_uniform(params, field.count)[off: off + 4] == bytes(4)
        params.cull_occlusion = True
        # a change of params reaches both the same way
        params.cull_frustum = False
        params.color_by = "natural"
        assert field.cull_uniform_buffer.data.tobytes() == uniforms.cull_uniform(params, field.count)
        # a frozen culling camera, and a transformed field (gravity into its local space)
        import pygfx as gfx

        cam = gfx.PerspectiveCamera(50, 4 / 3)
        cam.local.position = (0, 2, 9)
        cam.look_at((0, 0, 0))
        field.freeze_culling(cam, (640, 480))
        frozen = field.cull_uniform_buffer.data.tobytes()
        assert frozen == uniforms.cull_uniform(params, field.count, field.frozen_camera)
        assert frozen != uniforms.cull_uniform(params, field.count)
        field.local.rotation = (0.0, 0.0, math.sin(0.3), math.cos(0.3))
        field.local.position = (2.0, 0.0, 1.0)
        field.simulation.write_uniform(1, 0.0)
        values = engine_inputs.sim_uniform_values(params, field.count, field.colliders, world_matrix=field.world.matrix,
                                               steps=1)
        assert field.simulation.uniform_buffer.data.tobytes() == pack(SIM_LAYOUT, values)
        assert not np.allclose(values["gravity_dir"][:3], engine_inputs.sim_uniform_values(params, 1)["gravity_dir"][:3])
    finally:
        field.release()


def test_pack_refuses_a_field_the_layout_lacks():
    with pytest.raises(gw.GrassValueError, match="wind_speeed"):
        pack(CULL_LAYOUT, {"wind_speeed": 1.0})


def test_clock_rules_are_the_kernel_clocks():
    rules = engine_inputs.clock_rules(_params())
    assert rules["max_steps_per_frame"] == MAX_STEPS_PER_FRAME == SimClock().max_steps
    assert rules["dt"] == 0.01 and rules["wind_period"] > 0


def test_scene_style_is_the_kernel_scenes_sky_and_ground():
    """Every sky/ground value (colours, ground square, field, cover, far plane, fog) the
    browser is sent is the kernel scene's, byte for byte, and follows the params' fog."""
    from grasswidget.gpu.scene import GrassScene

    blades = gw.Blades.on_plane(256, size=6.0)
    params = gw.GrassParams(fog_density=0.02)
    scene = GrassScene(blades, size=(64, 48), params=params)
    try:
        layout = uniforms.SKY_GROUND_LAYOUT

        def kernel_bytes():
            mat = scene.sky_ground.material.uniform_buffer.data
            return pack(layout, {k: mat[k] for k, _ in layout})

        style = engine_inputs.scene_style(blades, scene.camera.depth_range[1], params)
        assert uniforms.sky_ground_uniform(style) == kernel_bytes()
        assert style["fog_density"] == 0.02 and 0 < style["cover"] < 1
        lo, hi = blades.v0.min(axis=0), blades.v0.max(axis=0)
        assert np.allclose(style["field"], [*(0.5 * (lo + hi))[[0, 2]], *(0.5 * (hi - lo))[[0, 2]]])
        # ground to the horizon: the square reaches past the far plane from the field's far edge
        assert style["ground"][3] >= 0.5 * 6.0 + scene.camera.depth_range[1]
        params.fog_density = 0.0  # a change reaches both engines the same way
        style = engine_inputs.scene_style(blades, scene.camera.depth_range[1], params)
        assert style["fog_density"] == 0.0 and uniforms.sky_ground_uniform(style) == kernel_bytes()
        scene.ground.visible = False  # the ground switch survives a rewrite of the values
        params.fog_density = 0.01
        assert scene.sky_ground.material.uniform_buffer.data["show_ground"] == 0
    finally:
        scene.release()


def test_kernel_grass_material_holds_the_bytes_the_browser_is_sent():
    """The blade material: the kernel's GrassMaterial (looks written by GrassField from
    the params) and the browser's material_uniform, both from engine_inputs, byte for byte."""
    from grasswidget.gpu.field import GrassField

    params = gw.GrassParams(color_variation=0.8, patch_size=7.5, dryness=0.45, translucency=0.2,
                            fog_density=0.03, blade_shape="quad")
    field = GrassField(gw.Blades.on_plane(64, seed=1), params=params)
    sent = lambda: uniforms.material_uniform(params, field.blades, field.colliders)  # noqa: E731
    try:
        field.prepare_sunlight()  # render_frame's, before every frame
        assert field.material.uniform_buffer.data.tobytes() == sent()
        params.dryness = 0.9
        params.fog_density = 0.0
        assert field.material.uniform_buffer.data.tobytes() == sent()
        assert field.material.dryness == pytest.approx(0.9)
        # the sunlight: the sun, the switch and a ball's shadow
        params.shadows, params.sun_elevation, params.sun_azimuth = True, 30.0, -120.0
        field.colliders = [gw.SphereCollider(center=(0.5, 0.3, -0.2), radius=0.3)]
        field.prepare_sunlight()
        assert field.material.uniform_buffer.data.tobytes() == sent()
        assert field.material.uniform_buffer.data.tobytes() != uniforms.material_uniform(params, field.blades)
    finally:
        field.release()


# ---------------------------------------------------------------------- engine.js under Node.js

_NODE_DRIVER = """
import { readFileSync } from "node:fs";
import { SimClock, clampOrbit } from %s;
const cases = JSON.parse(readFileSync(0, "utf8"));
const clock = new SimClock(cases.max_steps);
const steps = [];
for (const [now, playing, dt, scale] of cases.frames) {
  if (playing) { clock.start(now); steps.push(clock.frameSteps(now, dt, scale)); }
  else { clock.stop(); steps.push(clock.frameSteps(now, dt, scale)); }
}
const poses = cases.poses.map(([p, t]) => clampOrbit(p, t, cases.limits));
console.log(JSON.stringify({ steps, poses }));
"""


def _run_engine_js(cases):
    node = node_executable()
    url = (BROWSER_DIR / "engine.js").resolve().as_uri()
    out = subprocess.run([node, "--input-type=module", "-e", _NODE_DRIVER % json.dumps(url)],
                         input=json.dumps(cases), capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_engine_js_executes_the_python_clock_and_orbit_rules():
    rng = np.random.default_rng(7)
    # Frames: irregular wall times (a hiccup of 2 s: capped, slow motion), a pause, time_scale changes.
    t, frames = 10.0, []
    for k in range(300):
        t += float(rng.choice([0.004, 0.016, 0.017, 0.05, 0.3])) if k != 120 else 2.0
        playing = not (200 <= k < 220)
        frames.append([t, playing, 1.0 / 120.0, float(rng.choice([1.0, 0.25, 3.0]))])
    clock = SimClock(MAX_STEPS_PER_FRAME, now=lambda: now)
    expected = []
    for now, playing, dt, scale in frames:
        if playing:
            clock.start()
        else:
            clock.stop()
        expected.append(clock.frame_steps(dt, scale))

    blades = gw.Blades.on_plane(500, size=8.0)
    limits = engine_inputs.orbit_rules(blades, 100.0)
    assert OrbitLimits(**{k: tuple(v) if isinstance(v, list) else v for k, v in limits.items()}) == \
        OrbitLimits.for_field(blades.v0, blades.up, blades.height, 100.0)
    poses = [[list(rng.uniform(-40, 40, 3)), list(rng.uniform(-12, 12, 3))] for _ in range(200)]
    poses += [[[0.0, -5.0, 3.0], [0.0, 0.5, 0.0]], [[0.0, 50.0, 0.01], [0.0, 0.5, 0.0]], [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]]
    got = _run_engine_js({"max_steps": MAX_STEPS_PER_FRAME, "frames": frames, "limits": limits, "poses": poses})

    assert got["steps"] == expected
    assert max(expected) == MAX_STEPS_PER_FRAME and sum(expected) > 1000  # the cap and real play were exercised
    lim = OrbitLimits.for_field(blades.v0, blades.up, blades.height, 100.0)
    moved = 0
    for (p, t), (jp, jt) in zip(poses, got["poses"]):
        pp, pt = clamp_orbit(p, t, lim)
        assert np.allclose(jp, pp, atol=1e-9) and np.allclose(jt, pt, atol=1e-9), (p, t)
        moved += not np.allclose(pp, p)
    assert moved > 100  # most random poses were outside the limits


_NODE_HZB_DRIVER = """
import { readFileSync } from "node:fs";
import { hzbLayout } from %s;
const cases = JSON.parse(readFileSync(0, "utf8"));
console.log(JSON.stringify(cases.sizes.map(([w, h]) => hzbLayout(w, h, cases.row_align))));
"""


def test_engine_js_lays_out_the_depth_pyramid_as_reference_hzb_layout():
    """The browser engine sizes its occlusion pyramid per canvas with engine.js's hzbLayout
    (the canvas size is only known there): the same layout as reference.hzb_layout for the
    row alignment Python sends (BrowserShaders.occlusion's row_align)."""
    from grasswidget.browser.browser_wgsl import BrowserShaders
    from grasswidget.core.reference import HZB_MAX_LEVELS, hzb_layout

    node = node_executable()
    rng = np.random.default_rng(3)
    sizes = [[1, 1], [1, 7], [2, 1], [63, 64], [64, 64], [65, 33], [320, 240], [640, 480], [1920, 1080],
             [16384, 16384], [16384, 1]] + rng.integers(1, 5000, (60, 2)).tolist()
    spec = BrowserShaders.occlusion()
    url = (BROWSER_DIR / "engine.js").resolve().as_uri()
    out = subprocess.run([node, "--input-type=module", "-e", _NODE_HZB_DRIVER % json.dumps(url)],
                         input=json.dumps({"sizes": sizes, "row_align": spec["row_align"]}), capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    for (w, h), layout in zip(sizes, got):
        assert [tuple(level) for level in layout] == hzb_layout(w, h), (w, h)
    # the largest canvas Chromium allows still fits the level table Python sizes
    assert max(len(layout) for layout in got) <= spec["max_levels"] == HZB_MAX_LEVELS
    assert (4 * spec["row_align"]) % 256 == 0  # WebGPU copies depth into rows of a multiple of 256 bytes
