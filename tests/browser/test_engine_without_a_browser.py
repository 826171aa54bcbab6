"""The browser engine's Python side, without a browser: the WGSL it sends, the
uniforms it packs, errors, and the GrassWidget backend choice.

Runs without Chromium (not marked ``browser``); the engine in a real page is
tested in tests/e2e/test_browser_engine.py.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.browser import uniforms
from grasswidget.browser.kernel_pump import BrowserTimeoutError, wait_for
from grasswidget.browser.engine_widget import BrowserEngineWidget, wind_error_from_messages
from grasswidget.browser.browser_wgsl import BrowserShaders, binding_map
from grasswidget.core.shader_files import shader_dir
from conftest import node_executable


def _device():
    from grasswidget.gpu.adapter import ensure_device

    return ensure_device()


def test_browser_wgsl_compiles_and_declares_what_it_uses():
    """Every shader the browser gets is valid WGSL (naga here) and binds exactly the
    resources its text uses, each once, with the access the engine provides."""
    shaders = BrowserShaders.all()
    device = _device()
    texts = ([shaders[k] for k in ("simulate", "reset_args", "cull_count", "prefix_bands", "cull", "sky_ground", "balls",
                                   "inspect")]
             + shaders["blades"] + shaders["blades_flat"] + shaders["overlays"])
    occlusion = shaders["occlusion"]
    texts += [occlusion["cull"], *occlusion["hzb_levels"], *occlusion["blades"], *occlusion["blades_flat"]]
    raster = shaders["compute_raster"]
    texts += [shaders[k] for k in ("raster_clear", "raster_depth", "raster_payload", "raster_shade_args", "raster_shade")]
    texts += [raster[k] for k in ("second_depth", "second_payload", "second_shade_args", "second_shade", "resolve")]
    # The draws with the sunlight's maths compiled in (GrassParams.shadows on), and without it in the others.
    sunlit = BrowserShaders.all(sunlight=True)
    sunlit_draws = (sunlit["blades"] + sunlit["blades_flat"] + sunlit["occlusion"]["blades"]
                    + sunlit["occlusion"]["blades_flat"] + [sunlit["sky_ground"], sunlit["raster_shade"],
                                                            sunlit["compute_raster"]["second_shade"]])
    assert all("sun_and_sky(" in sh["code"] for sh in sunlit_draws)
    assert not any("sun_and_sky(" in sh["code"] for sh in texts)
    texts += sunlit_draws
    # A field to the horizon (Blades.horizon): its culling passes wrap the blades around the camera and
    # every pass that draws blades scales their width by their level's weight; no other field gets any of it.
    following = BrowserShaders.all(follow_camera=True)
    wrapping = [following["cull_count"], following["cull"], following["occlusion"]["cull"]]
    weighing = (following["blades"] + following["blades_flat"] + following["occlusion"]["blades"]
                + following["occlusion"]["blades_flat"]
                + [following[k] for k in ("raster_depth", "raster_payload")]
                + [following["compute_raster"][k] for k in ("second_depth", "second_payload")])
    assert all("follow_camera(i)" in sh["code"] for sh in wrapping)
    assert all("blade_weight(" in sh["code"] for sh in wrapping + weighing)
    assert not any("blade_weight(" in sh["code"] or "follow_camera(" in sh["code"] for sh in texts)
    assert all({b["name"]: b["kind"] for b in sh["bindings"]}["s_blades"] == "storage" for sh in wrapping)
    texts += wrapping + weighing
    for sh in texts:
        device.create_shader_module(code=sh["code"])
        names = [b["name"] for b in sh["bindings"]]
        numbers = [b["binding"] for b in sh["bindings"]]
        assert len(set(names)) == len(names) and len(set(numbers)) == len(numbers)
        assert [{k: v for k, v in b.items() if k != "resource"} for b in sh["bindings"]] == binding_map(sh["code"])
    kinds = {b["name"]: b["kind"] for b in shaders["simulate"]["bindings"]}
    assert kinds == {"u_sim": "uniform", "s_blades": "storage", "s_collision": "storage",
                     "s_colliders": "read-only-storage", "s_collider_grid": "read-only-storage"}
    kinds = {b["name"]: b["kind"] for b in shaders["blades"][0]["bindings"]}
    assert kinds["s_blades"] == "read-only-storage" and kinds["u_material"] == "uniform"
    # The same files: the blade math of the package is in the text, not a copy.
    math_src = (shader_dir() / "blade_math.wgsl").read_text()
    fn = re.search(r"fn validate_length\([^)]*\)[^{]*\{[^}]*\}", math_src).group(0)
    assert fn in shaders["simulate"]["code"] and fn in shaders["cull"]["code"]
    assert len(shaders["blades"]) == 4 and "const SEGMENTS: u32 = 8u;" in shaders["blades"][0]["code"]
    # The natural view's ribbons carry no flat-colour path (it costs GPU draw time); the colour-by set
    # does, and its fifth draw is the culled blades (color_by "cull"), from the list the cull pass fills.
    assert all("flat_color" not in b["code"] for b in shaders["blades"])
    assert len(shaders["blades_flat"]) == 5 and all("flat_color" in b["code"] for b in shaders["blades_flat"])
    assert [b["culled"] for b in shaders["blades_flat"]] == [False] * 4 + [True]
    assert {b["name"] for b in shaders["blades_flat"][4]["bindings"]} >= {"s_culled"}
    offset = BrowserShaders.all()["color_by_offset"]
    from grasswidget.browser.uniforms import CULL_LAYOUT, offsets
    assert offset == offsets(CULL_LAYOUT)["color_by"][0]
    assert {b["name"] for b in shaders["cull"]["bindings"]} >= {"s_culled", "s_culled_args"}
    # Every compute pass of a frame names a shader that is sent.
    assert [p["shader"] for p in shaders["compute_passes"]] == [
        "reset_args", "raster_clear_args", "raster_clear", "cull_count", "prefix_bands", "cull", "raster_args", "raster_depth", "raster_payload",
        "raster_shade_args", "raster_shade",
        "inspect"]
    # The inspector: the kernel's inspect.wgsl (its forces from blade_math's tip_step and collisions.wgsl),
    # run only while blades are inspected; its lines and points and the frozen frustum are overlays.
    assert shaders["compute_passes"][-1]["only_if"] == "inspecting"
    assert shaders["compute_passes"][-1]["sim_uniform"] == "now"
    assert "let moved = tip_step(" in shaders["inspect"]["code"]
    kinds = {b["name"]: b["kind"] for b in shaders["inspect"]["bindings"]}
    assert kinds["u_inspect"] == "uniform" and kinds["s_forces"] == "storage" and kinds["s_segments"] == "storage"
    assert [(o["name"], o["only_if"], o["bindings"][1]["resource"]) for o in shaders["overlays"]] == [
        ("frustum", "frozen", "s_frustum"), ("inspector lines", "inspecting", "s_segments"),
        ("inspector points", "inspecting", "s_points")]
    # Occlusion culling: the first phase's passes read the seen flags; the second phase writes them and
    # fills s_occlusion_args (bound as its s_args); each pyramid level writes s_hzb; the second phase's
    # ribbons read their lists from the end; comments naming a resource bind nothing.
    kinds = {b["name"]: b["kind"] for b in shaders["cull"]["bindings"]}
    assert kinds["s_occlusion_flags"] == "read-only-storage" and "s_hzb" not in kinds
    assert {b["name"] for b in shaders["reset_args"]["bindings"]} >= {"s_occlusion_args"}
    second = {b["name"]: (b["kind"], b.get("resource")) for b in occlusion["cull"]["bindings"]}
    assert second["s_occlusion_flags"][0] == "storage" and second["s_args"] == ("storage", "s_occlusion_args")
    assert second["s_hzb"][0] == second["s_hzb_levels"][0] == "read-only-storage"
    assert len(occlusion["hzb_levels"]) == occlusion["max_levels"] - 1
    for k, level in enumerate(occlusion["hzb_levels"], start=1):
        assert {b["name"]: b["kind"] for b in level["bindings"]} == {"s_hzb": "storage",
                                                                      "s_hzb_levels": "read-only-storage"}
        assert f"s_hzb_levels[{k}u]" in level["code"]
    assert len(occlusion["blades"]) == len(occlusion["blades_flat"]) == 4
    assert all("n_blades - 1u - in.instance_index" in b["code"] for b in occlusion["blades"] + occlusion["blades_flat"])
    assert occlusion["phase_offset"] == offsets(CULL_LAYOUT)["occlusion_phase"][0]
    # The compute rasterizer: the kernel's raster.wgsl and raster_resolve.wgsl; its passes run
    # only while u_cull.compute_raster is on, bound per view size (the clear over the rows written); the culling
    # lists thin blades into s_raster (written there, read by the walks); the walks do atomic depth
    # tests; the resolve writes frag_depth and reads the words; its colour-by variant has the
    # "drawn in compute" colour; the device must allow the most storage buffers one shader binds.
    sized = [p for p in shaders["compute_passes"] if p.get("sized")]
    # The walks run a thread per listed blade: dispatched indirectly from what the args step wrote.
    assert [(p["shader"], p["dispatch"], p["only_if"]) for p in sized] == [
        ("raster_clear_args", "one", "compute_raster"), ("raster_clear", "raster_listed", "compute_raster"),
        ("raster_args", "one", "compute_raster"),
        ("raster_depth", "raster_listed", "compute_raster"), ("raster_payload", "raster_listed", "compute_raster"),
        ("raster_shade_args", "one", "compute_raster"), ("raster_shade", "raster_listed", "compute_raster")]
    # The clear runs over the rows the last frame wrote, the shade over the rows the walks wrote: their
    # workgroups at their own offsets.
    assert [p.get("indirect_offset", 0) for p in sized] == [0, 16, 0, 0, 0, 0, 32]
    assert "rows_dispatch(4u);" in shaders["raster_clear_args"]["code"]  # the clear's workgroups at word 4
    assert "s_raster_dispatch[at] = x;" in shaders["raster_clear_args"]["code"]
    names = [p["shader"] for p in shaders["compute_passes"]]
    assert names.index("raster_clear") < names.index("cull_count") < names.index("cull") < names.index("raster_args")
    for sh in (shaders["raster_args"], raster["second_args"]):
        kinds = {b["name"]: b["kind"] for b in sh["bindings"]}
        assert kinds["s_raster_dispatch"] == "storage" and "s_raster_depth" not in kinds
        assert "s_raster_dispatch[0] = x;" in sh["code"]
    assert "atomicStore(&s_raster_args[2], RASTER_EMPTY);" in shaders["raster_args"]["code"]  # rows written: none
    assert "atomicStore(&s_raster_args[2]" not in raster["second_args"]["code"]  # the first phase's rows kept
    assert raster["dispatch_words"] == 12 and raster["shade_offset"] == 32 and (raster["rows_at"], raster["rows_words"]) == (2, 2)
    for sh in (shaders["cull"], occlusion["cull"]):
        kinds = {b["name"]: b["kind"] for b in sh["bindings"]}
        assert kinds["s_raster"] == "storage" and kinds["s_raster_args"] == "storage"
        assert "atomicAdd(&s_raster_args[0]" in sh["code"] and "s_raster[wg_base[RASTER] + slot] = i;" in sh["code"]
    for sh in (shaders["raster_depth"], shaders["raster_payload"], raster["second_depth"], raster["second_payload"]):
        kinds = {b["name"]: b["kind"] for b in sh["bindings"]}
        assert kinds["s_raster"] == "read-only-storage" and kinds["s_raster_depth"] == "storage"
        assert "s_raster_dispatch" not in kinds  # their indirect arguments: no storage use in the same dispatch
        assert "var<storage, read_write> s_raster_depth: array<atomic<u32>>" in sh["code"]
    assert "atomicMin(&s_raster_depth[index], depth);" in shaders["raster_depth"]["code"]
    assert "let first = atomicLoad(&s_raster_args[1]);" in raster["second_depth"]["code"]
    sh = raster["resolve"]
    kinds = {b["name"]: b["kind"] for b in sh["bindings"]}
    assert kinds["s_raster_depth"] == kinds["s_raster_color"] == kinds["s_raster_args"] == "read-only-storage"
    # only the rows the walks wrote run the fragment shader; none written: no fragment shaded
    assert "select(0.0, 1.0, s_raster_args[2] <= ~s_raster_args[3])" in sh["code"]
    # the colours come from the shade step (a compute pass): no shading per fragment
    assert "@builtin(frag_depth) depth: f32" in sh["code"] and "blade_shade(" not in sh["code"]
    for sh in (shaders["raster_shade"], raster["second_shade"]):
        kinds = {b["name"]: b["kind"] for b in sh["bindings"]}
        assert kinds["s_raster_color"] == kinds["s_raster_depth"] == "storage" and "blade_shade(" in sh["code"]
        assert "const RASTER_COLOR = vec3<f32>(1.000000, 1.000000, 1.000000);" in sh["code"]  # the colour-by views'
    for sh in (shaders["raster_shade_args"], raster["second_shade_args"]):
        assert "rows_dispatch(8u);" in sh["code"] and "s_raster_dispatch[at] = x;" in sh["code"]  # at word 8
    assert all("@builtin(frag_depth)" not in b["code"] for b in shaders["blades"])
    at = offsets(CULL_LAYOUT)
    assert (raster["switch_offset"], raster["width_offset"], raster["height_offset"]) == (
        at["compute_raster"][0], at["raster_width"][0], at["raster_height"][0])
    assert shaders["max_storage_buffers"] == max(
        sum(b["kind"] != "uniform" for b in sh["bindings"]) for sh in texts) == len(
        [b for b in occlusion["cull"]["bindings"] if b["kind"] != "uniform"])
    # Sky and ground: the kernel engine's own file, its u_material bound to the engine's u_sky_ground buffer.
    sky = shaders["sky_ground"]
    body = (shader_dir() / "sky_ground.wgsl").read_text()
    assert re.search(r"let s = \(g\.y - near\.y\) / dir\.y;", body) and "let s = (g.y - near.y) / dir.y;" in sky["code"]
    bound = {b["name"]: b.get("resource", b["name"]) for b in sky["bindings"]}
    assert bound == {"u_stdinfo": "u_stdinfo", "u_material": "u_sky_ground"}


def test_custom_wind_is_inserted_and_errors_map_to_snippet_lines():
    body = "let k = 2.0;\nreturn vec3<f32>(k * oops, 0.0, 0.0);"
    sh = BrowserShaders.simulate(body)
    lines = sh["code"].splitlines()
    line = next(i for i, text in enumerate(lines, 1) if "k * oops" in text)
    err = wind_error_from_messages([{"line": line, "column": 22, "message": "unresolved identifier 'oops'"}],
                                   sh["code"], body)
    assert isinstance(err, gw.WindShaderError) and isinstance(err, ValueError)
    assert err.line == 2 and "wind_wgsl line 2" in str(err) and "k * oops" in str(err)
    outside = wind_error_from_messages([{"line": 1, "column": 1, "message": "boom"}], sh["code"], body)
    assert outside.line is None and "boom" in str(outside)


def test_uniform_layouts_match_wgsl_offsets():
    """Offsets follow WGSL's uniform rules, and the packed bytes hold each parameter at its offset."""
    assert uniforms.offsets(uniforms.SIM_LAYOUT)["wind_center"][0] == 48
    assert uniforms.offsets(uniforms.SIM_LAYOUT)["gravity"][0] == 64  # no collider array: the count is free
    assert uniforms.struct_size(uniforms.STDINFO_LAYOUT) == 4 * 64 + 16 + 16  # + ndc_offset
    p = gw.GrassParams(wind_strength=7.5, wind_direction=90.0, wind_field="vortex", dt=0.01)
    raw = uniforms.sim_uniform(p, 1234, [gw.SphereCollider(center=(1, 2, 3), radius=0.5)])
    off = uniforms.offsets(uniforms.SIM_LAYOUT)

    def read(name, dtype="<f4", count=1):
        return np.frombuffer(raw, dtype, count, off[name][0])

    assert read("wind_strength")[0] == np.float32(7.5)
    assert read("wind_field", "<i4")[0] == 2 and read("n_blades", "<u4")[0] == 1234
    assert np.allclose(read("wind_dir", count=4), [0, 1, 0, 0], atol=1e-7)
    assert read("n_colliders", "<i4")[0] == 1
    assert uniforms.clock(p) == {"dt": 0.01, "wind_period": p.wind_wavelength / p.wind_speed,
                                 "max_steps_per_frame": 64}


def test_the_browser_gets_the_kernels_collider_arrays():
    """The browser view sends the same sphere and grid arrays the kernel engine uploads."""
    from grasswidget.core.collider_grid import build_collider_grid, root_bounds

    blades = gw.Blades.on_plane(512, size=10.0, seed=2)
    view = BrowserEngineWidget(blades)
    ball = gw.SphereCollider(center=(1, 0.5, 2), radius=0.5)
    view.colliders.append(ball)
    rows = np.random.default_rng(0).uniform(0.1, 4.0, (300, 4))
    view.colliders.set_array(rows)
    view.colliders_changed()
    spheres = np.concatenate([[ball.as_vec4()], rows])
    grid = build_collider_grid(spheres, root_bounds(blades.v0), blades.height.max())
    assert view.collider_spheres == spheres.astype(np.float32).tobytes() == grid.sphere_data().tobytes()
    assert view.collider_grid == grid.words().tobytes() and grid.nx * grid.nz > 1
    assert len(view.collider_spheres) <= view.collider_buffer_bytes[0]
    assert len(view.collider_grid) <= view.collider_buffer_bytes[1]
    assert np.frombuffer(view.sim_uniform, "<i4", 1, uniforms.offsets(uniforms.SIM_LAYOUT)["n_colliders"][0])[0] == 301
    view.close()


def test_requests_outside_a_notebook_raise_timeout_naming_the_browser_view():
    with pytest.raises(BrowserTimeoutError, match="browser view"):
        wait_for(lambda: None, 1.0, "read_state() from the browser view")
    view = BrowserEngineWidget(gw.Blades.on_plane(64))
    with pytest.raises(TimeoutError, match="browser view"):
        view.read_state(timeout=0.5)
    view.close()


def test_backend_argument_and_browser_widget_api():
    with pytest.raises(ValueError, match="backend must be one of 'kernel', 'browser', 'auto'"):
        gw.GrassWidget(16, backend="gpu")
    w = gw.GrassWidget(256, backend="browser", size=(320, 240))
    try:
        assert w.backend == "browser" and w.scene is None
        cam = w.camera_state
        assert set(cam) == {"position", "target", "fov_deg"} and cam["fov_deg"] == 45.0
        w.camera_state = {"fov_deg": 60, "target": (0, 0, 0)}
        assert w.camera_state["fov_deg"] == 60 and w.camera_state["target"] == (0.0, 0.0, 0.0)
        with pytest.raises(ValueError, match="fov_deg"):
            w.camera_state = {"fov_deg": 500}
        with pytest.raises(ValueError, match="position"):
            w.camera_state = {"position": (1, float("nan"), 0)}
        w.reset_camera()
        assert w.camera_state == cam
        # Parameters reach the browser as packed uniforms.
        w.params.wind_strength = 33.0
        off = uniforms.offsets(uniforms.SIM_LAYOUT)["wind_strength"][0]
        assert np.frombuffer(w.view.engine_widget.sim_uniform, "<f4", 1, off)[0] == np.float32(33.0)
        w.ball.enabled = True
        assert w.view.engine_widget.balls == [list(map(float, w.ball.collider.as_vec4()))]
        # An explicit backend="browser" gets the sunlight's default from its engine's adapter report
        # (gpu_status "ok" and the adapter in words), as the kernel's adapter sets it: a GPU, on.
        ew = w.view.engine_widget
        assert w.params.shadows is False  # no report yet: a CPU's default
        ew.gpu_status = {"state": "ok", "detail": "nvidia ampere NVIDIA GeForce RTX 4090"}
        assert w.params.shadows is True
        # The sunlight's switch selects the draws' shaders (its maths compiled in only while on).
        for on in (True, False):
            w.params.shadows = on
            draws = ew.shaders["blades"] + ew.shaders["occlusion"]["blades_flat"] + [ew.shaders["sky_ground"]]
            assert all(("sun_and_sky(" in sh["code"]) == on for sh in draws)
            assert ew.shaders == BrowserShaders.all(sunlight=on)
        with pytest.raises(ValueError, match="number of steps"):
            w.step(-1)
    finally:
        w.close()


def test_browser_messages_move_the_ball_and_never_raise():
    """What the page sends (shift + drag, the steps simulated while rolling, junk) reaches
    the ball, and a malformed message shows on the message line instead of raising."""
    w = gw.GrassWidget(256, backend="browser", size=(320, 240))
    view = w.view.engine_widget
    try:
        center = w.ball.collider.center
        view.handle_message({"type": "ball", "phase": "move", "x": None, "z": None})  # on the sky, not pressed
        assert not w.ball.enabled and w.ball.collider.center == center
        view.handle_message({"type": "ball", "phase": "down", "x": None, "z": None})  # a press on the sky
        assert w.ball.enabled and w.ball.collider.center == center  # on, where it was
        w.ball.enabled = False
        view.handle_message({"type": "ball", "phase": "down", "x": 1.0, "z": -0.5})
        assert w.ball.enabled and w.ball.collider.center[0] == 1.0 and w.ball.collider.center[2] == -0.5
        assert view.balls == [list(map(float, w.ball.collider.as_vec4()))]
        w.ball.rolling = True
        assert view.report_steps
        view.handle_message({"type": "steps", "steps": 1})    # onto its circle
        before = w.ball.collider.center
        view.handle_message({"type": "steps", "steps": 60})   # 0.5 s of simulated time
        moved = np.linalg.norm(np.subtract(w.ball.collider.center, before))   # a chord of the rolled arc
        arc = w.ball.roll_speed * 60 * w.params.dt
        assert 0.9 * arc < moved <= arc + 1e-9
        assert view.balls == [list(map(float, w.ball.collider.as_vec4()))]
        view.handle_message({"type": "ball", "phase": "move", "x": "nowhere"})
        assert "could not convert" in w.panel.message_line.value
        view.handle_message({"type": "stats", "fps": 12.5, "visible": [1, 2, 3, 4], "steps": 30,
                                    "step_count": 99, "frame_size": [320, 240]})
        assert w.stats["fps"] == 12.5 and w.stats["visible"] == 10 and "12.5 frames/s" in w.panel.stats_line.value
        view.handle_message({"type": "gpu_status"}, None)   # unknown kinds are ignored
    finally:
        w.close()


def test_browser_stats_measure_the_speed_of_time(monkeypatch):
    """The browser's steps between two stats messages give the speed of simulated time, as
    the kernel's clock does: "real time" at full speed, "slow motion 0.05x" when a frame
    owed more than the step cap got only the cap, and no claim before it is measured."""
    import time

    wall = [100.0]
    monkeypatch.setattr(time, "perf_counter", lambda: wall[0])
    w = gw.GrassWidget(256, backend="browser", size=(320, 240))
    view = w.view.engine_widget
    try:
        view.handle_message({"type": "stats", "fps": 30.0, "visible": [10], "steps": 60, "step_count": 60})
        assert w.stats["sim_speed"] is None and "real time" not in w.panel.stats_line.value  # first message
        wall[0] += 0.5
        view.handle_message({"type": "stats", "fps": 30.0, "visible": [10], "steps": 60, "step_count": 120})
        assert w.stats["sim_speed"] == pytest.approx(60 * w.params.dt / 0.5)
        assert "30.0 frames/s" in w.panel.stats_line.value and "real time" in w.panel.stats_line.value
        wall[0] += 10.0  # one frame in 10 s, capped at 64 steps
        view.handle_message({"type": "stats", "fps": 0.1, "visible": [10], "steps": 64, "step_count": 184})
        assert "0.1 frames/s" in w.panel.stats_line.value and "slow motion 0.05x" in w.panel.stats_line.value, w.panel.stats_line.value
    finally:
        w.close()


def test_kernel_widget_camera_state_both_ways():
    w = gw.GrassWidget(64)
    try:
        assert w.backend == "kernel"
        w.camera_state = {"position": (1.0, 2.0, 9.0), "target": (0.0, 1.0, 0.0), "fov_deg": 30.0}
        cam = w.camera_state
        assert np.allclose(cam["position"], (1, 2, 9)) and np.allclose(cam["target"], (0, 1, 0))
        assert cam["fov_deg"] == pytest.approx(30.0)
        forward = -np.asarray(w.scene.camera.world.matrix)[:3, 2]
        assert np.allclose(forward, np.subtract((0, 1, 0), (1, 2, 9)) / np.linalg.norm((1, 1, 9)), atol=1e-5)
        with pytest.raises(ValueError, match="differ"):
            w.camera_state = {"position": (0.0, 1.0, 0.0)}
    finally:
        w.close()


_DOWNSAMPLE_DRIVER = """
import { readFileSync } from "node:fs";
import { downsample } from %s;
const c = JSON.parse(readFileSync(0, "utf8"));
const out = downsample(Uint8Array.from(c.src), c.width, c.height, c.row, c.bgra, c.filter);
console.log(JSON.stringify(Array.from(out)));
"""


def _cubic(t, b=1 / 3, c=1 / 3):
    """pygfx's ssaa.wgsl cubicWeights (Mitchell with B = C = 1/3), written out here."""
    t = abs(t)
    if t < 1:
        return ((12 - 9 * b - 6 * c) * t ** 3 + (-18 + 12 * b + 6 * c) * t ** 2 + (6 - 2 * b)) / 6
    if t <= 2:
        return ((-b - 6 * c) * t ** 3 + (6 * b + 30 * c) * t ** 2 + (-12 * b - 48 * c) * t + (8 * b + 24 * c)) / 6
    return 0.0


@pytest.mark.parametrize("bgra", [False, True])
def test_browser_export_filter_is_pygfx_supersampling(bgra):
    """engine.js's downsample (the browser's anti-aliased Save PNG and save_png), run with
    Node.js on random pixels, gives what a direct 2D Mitchell filter in linear light over
    the clamped picture gives (pygfx's SSAA of the kernel's exports), to 1/255."""
    import json
    import subprocess

    from grasswidget.browser.engine_widget import HERE as browser_dir
    from grasswidget.core.engine_inputs import export_filter

    node = node_executable()
    f, (w, h) = 2, (9, 7)
    rng = np.random.default_rng(4)
    img = rng.integers(0, 256, (h * f, w * f, 3))
    img[:, : w * f // 2] //= 8  # a dark half: a hard edge, as at blade borders
    row = 4 * w * f + 8  # rows padded, as WebGPU's copies are
    buf = np.zeros((h * f, row), np.uint8)
    rgba = np.concatenate([img[..., ::-1] if bgra else img, np.full((h * f, w * f, 1), 255)], axis=2)
    buf[:, : 4 * w * f] = rgba.reshape(h * f, -1)
    url = (browser_dir / "engine.js").resolve().as_uri()
    case = {"src": buf.ravel().tolist(), "width": w, "height": h, "row": row, "bgra": bgra,
            "filter": export_filter(f)}
    run = subprocess.run([node, "--input-type=module", "-e", _DOWNSAMPLE_DRIVER % json.dumps(url)],
                         input=json.dumps(case), capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    got = np.array(json.loads(run.stdout)).reshape(h, w, 4)

    lin = img / 255.0
    lin = np.where(lin <= 0.04045, lin / 12.92, ((lin + 0.055) / 1.055) ** 2.4)
    want = np.zeros((h, w, 3))
    for y in range(h):
        for x in range(w):
            acc, total = np.zeros(3), 0.0
            for sy in range(f * y - 4, f * y + 6):
                for sx in range(f * x - 4, f * x + 6):
                    wt = _cubic((sx + 0.5 - f * (x + 0.5)) / f) * _cubic((sy + 0.5 - f * (y + 0.5)) / f)
                    acc += wt * lin[min(max(sy, 0), h * f - 1), min(max(sx, 0), w * f - 1)]
                    total += wt
            want[y, x] = acc / total
    want = np.clip(want, 0, 1)
    want = np.round(255 * np.where(want <= 0.0031308, 12.92 * want, 1.055 * want ** (1 / 2.4) - 0.055))
    assert np.abs(got[..., :3] - want).max() <= 1
    assert (got[..., 3] == 255).all()
    # and it is a filter, not a copy: the hard edge is softened
    assert np.abs(got[..., :3] - img[::f, ::f]).max() > 20


def test_a_wind_past_the_size_limits_is_refused_before_the_page_compiles_it():
    """A wind nested 3,500 deep would crash the page's compiler: refused in the kernel at its
    line, before any request (no page answers here), the old wind kept; assigned, the error is
    the view's error and params.wind_wgsl goes back."""
    view = BrowserEngineWidget(gw.Blades.on_plane(64))
    try:
        nested = "return vec3<f32>(" + "(" * 3500 + "1.0" + ")" * 3500 + ", 0.0, 0.0);"
        with pytest.raises(gw.WindShaderError) as info:
            view.set_wind_wgsl("let k = 2.0;\n" + nested, timeout=0.5)
        assert info.value.line == 2 and "nested more than 48 deep" in str(info.value)
        assert view.params.wind_wgsl == ""
        view.params.wind_wgsl = nested
        assert view.params.wind_wgsl == "" and "wind_wgsl line 1" in view.errors[-1]
    finally:
        view.close()


def test_browser_stats_say_how_old_they_are_and_when_the_engine_rests(monkeypatch):
    """Issue 37, item 4: each stats message is a frame drawn; the stats say how long ago
    (``frame_age_s``), turn ``stale`` a stats interval after it while playing, ``waiting`` after
    WAITING_AFTER_S, and an engine at rest (no view on screen: its "rest" message) says so, in
    ``w.stats`` and the status line, also after a change made while it rests."""
    import time

    from grasswidget.core.engine_inputs import WAITING_AFTER_S

    wall = [100.0]
    monkeypatch.setattr(time, "perf_counter", lambda: wall[0])
    w = gw.GrassWidget(256, backend="browser", size=(320, 240))
    page = w.view.engine_widget
    msg = {"type": "stats", "fps": 12.5, "visible": [1, 2, 3, 4], "steps": 6, "step_count": 6,
           "frame_size": [320, 240]}
    try:
        w.play()
        s = w.stats
        assert s["frame_age_s"] is None and not s["stale"] and not s["at_rest"] and not s["waiting"]
        page.handle_message(msg)
        s = w.stats
        assert s["frame_age_s"] == 0.0 and not s["stale"] and "12.5 frames/s" in w.panel.stats_line.value
        wall[0] += 0.3
        assert w.stats["frame_age_s"] == pytest.approx(0.3) and not w.stats["stale"]
        wall[0] += 0.5  # no message for longer than the stats interval (0.5 s) while playing
        assert w.stats["stale"] and not w.stats["waiting"]
        wall[0] += WAITING_AFTER_S
        assert w.stats["waiting"]
        page.handle_message(msg)
        assert not w.stats["stale"] and not w.stats["waiting"]
        page.handle_message({"type": "rest", "message": "", "step_count": 6})  # scrolled out of sight
        s = w.stats
        assert s["at_rest"] and s["stale"] and "at rest (out of sight)" in w.panel.stats_line.value
        wall[0] += 30.0
        w.params.cull_orientation = False  # from a cell, while it rests: nothing is drawn
        s = w.stats
        assert s["visible"] == 10 and s["stale"] and s["frame_age_s"] == pytest.approx(30.0)
        line = w.panel.stats_line.value
        assert "at rest (out of sight)" in line and "10 of 256 blades drawn" in line and "last frame 30 s ago" in line
        page.handle_message(msg)  # back in sight: a frame drawn
        s = w.stats
        assert not s["at_rest"] and not s["stale"] and "at rest" not in w.panel.stats_line.value
    finally:
        w.close()
