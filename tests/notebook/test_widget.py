"""GrassWidget without a browser: controls <-> params, errors, PNG/animation export, GPU memory.

No kernel and no view here: the jupyter canvas never gets a size or a draw
request, so pictures come from offscreen renders (save_png, save_animation)
and the draw function is called directly after a fake browser resize event.
"""

import gc
import re
from pathlib import Path

import numpy as np
import pytest
from traitlets import TraitError

import grasswidget as gw
from conftest import WIDGET_SIZE, grass_mask

ipywidgets = pytest.importorskip("ipywidgets")
pytest.importorskip("jupyter_rfb")

SIZE = WIDGET_SIZE  # the conftest's ``widget`` fixture has this view size


def _resize(w, width=SIZE[0], height=SIZE[1], ratio=1.0):
    """What the browser sends when a view appears."""
    w.canvas.handle_event({"event_type": "resize", "width": width, "height": height, "pixel_ratio": ratio})


def test_layout_and_labels(widget):
    from rendercanvas.jupyter import RenderCanvas

    assert isinstance(widget, ipywidgets.VBox)
    assert isinstance(widget.canvas, RenderCanvas)
    assert widget.children[0].children[0] is widget.canvas  # the view, with the lab bench under it
    labels = {s.description for s in widget.panel.sliders.values()}
    assert labels == {"blades", "wind strength (m/s²)", "wind direction (°)", "gust speed (m/s)", "gravity (m/s²)",
                      "stiffness ×", "time (× real time)"}
    looks = {s.description for s in widget.panel.look_sliders.values()}
    assert looks == {"colour variety", "patch size (m)", "dry grass", "sunlit tips", "fog (1/m)", "sun height (°)",
                     "sun direction (°)"}
    tip = widget.panel.sliders["wind_strength"].tooltip
    assert tip.startswith(gw.GrassParams.class_traits()["wind_strength"].help) and "0 to 200 m/s²" in tip
    assert [c.description for c in widget.panel.checkboxes.values()] == [
        "orientation culling", "frustum culling", "distance culling", "LOD"]
    choices = widget.panel.switch_choices  # the switches decided by measuring: auto / on / off
    assert [(c.dropdown.description, c.dropdown.value) for c in choices.values()] == [
        ("occlusion culling", "auto"), ("compute raster", "auto")]
    assert widget.panel.wind_field_dropdown.options == tuple(gw.params.WIND_FIELDS)
    texts = {b.description for b in (widget.panel.play_button, widget.panel.step_button, widget.panel.reset_blades_button,
                                      widget.panel.reset_camera_button, widget.panel.save_button)}
    assert texts == {"Pause", "Step", "Reset blades", "Reset camera", "Save PNG"}
    assert widget.scene.params is widget.params
    assert widget.canvas.quality in range(1, 101)


def test_streaming_defaults_per_adapter(widget):
    from grasswidget.gpu.adapter import is_cpu_adapter

    d = gw.widget.streaming_defaults(is_cpu_adapter())
    assert widget.max_fps == d["max_fps"] and widget.canvas.quality == d["quality"]
    _resize(widget, ratio=2.0)  # a HiDPI browser
    expected = 1.0 if is_cpu_adapter() else 2.0
    assert widget.canvas.get_physical_size() == (int(SIZE[0] * expected), int(SIZE[1] * expected))
    assert gw.widget.streaming_defaults(True)["max_pixel_ratio"] == 1.0
    assert gw.widget.streaming_defaults(True)["max_fps"] < gw.widget.streaming_defaults(False)["max_fps"]


def test_pixel_ratio_override():
    w = gw.GrassWidget(blades=64, size=SIZE, pixel_ratio=0.5)
    try:
        _resize(w, ratio=1.0)
        assert w.canvas.get_physical_size() == (SIZE[0] // 2, SIZE[1] // 2)
        assert w.scene.renderer.pixel_ratio == 0.5  # renders a quarter of the pixels, not just sends them
        w.view.draw()
    finally:
        w.close()
    with pytest.raises(ValueError, match="pixel_ratio"):
        gw.GrassWidget(blades=64, size=SIZE, pixel_ratio=0)


def test_controls_change_params_and_back(widget):
    p = widget.params
    widget.panel.sliders["wind_strength"].value = 33.5
    assert p.wind_strength == 33.5
    p.wind_strength = 12.0
    assert widget.panel.sliders["wind_strength"].value == 12.0
    widget.panel.sliders["stiffness_scale"].value = 2.5
    assert p.stiffness_scale == 2.5
    p.gravity = 20.0
    assert widget.panel.sliders["gravity"].value == 20.0
    p.wind_direction = -90
    assert widget.panel.sliders["wind_direction"].value == -90
    for name, cb in widget.panel.checkboxes.items():
        cb.value = False
        assert getattr(p, name) is False
        setattr(p, name, True)
        assert cb.value is True
    for name, choice in widget.panel.switch_choices.items():
        choice.dropdown.value = "off"
        assert getattr(p, name) is False
        setattr(p, name, True)
        assert choice.dropdown.value == "on"
        setattr(p, name, "auto")
        assert choice.dropdown.value == "auto"
    widget.time_scale = 0.5
    assert widget.panel.sliders["time_scale"].value == 0.5
    widget.panel.sliders["time_scale"].value = 2.0
    assert widget.time_scale == 2.0
    assert widget.steps_per_frame == round(2.0 / widget.max_fps / p.dt)
    # ipywidgets.link from user code works both ways too
    other = ipywidgets.FloatSlider(min=0, max=50)
    link = ipywidgets.link((other, "value"), (p, "wind_speed"))
    other.value = 7.0
    assert p.wind_speed == 7.0 and widget.panel.sliders["wind_speed"].value == 7.0
    p.wind_speed = 4.0
    assert other.value == 4.0
    link.unlink()


def test_sun_controls_in_the_looks_row(widget):
    """The looks row's sun height and direction sliders and the shadows checkbox drive the params
    both ways; a bad value raises the project's error naming the parameter and its range, the
    control snaps back and the message line says why; the picture follows the sun."""
    panel, p = widget.panel, widget.params
    height, direction, shadows = panel.look_sliders["sun_elevation"], panel.look_sliders["sun_azimuth"], \
        panel.shadows_checkbox
    assert "sun height" in height.description and "sun direction" in direction.description
    assert shadows in panel.looks_row.children and height in panel.looks_row.children
    assert (height.min, height.max) == (5.0, 90.0) and (direction.min, direction.max) == (-360.0, 360.0)
    assert shadows.value is p.shadows is False  # the test machine's CPU adapter: off by default
    shadows.value = True
    assert p.shadows is True
    p.shadows = False
    assert shadows.value is False
    height.value = 30.0
    assert p.sun_elevation == 30.0
    p.sun_azimuth = -45.0
    assert direction.value == -45.0
    with pytest.raises(gw.ParameterError, match=r"sun_elevation must be a finite number in \[5, 90\] degrees"):
        p.sun_elevation = 95.0
    with pytest.raises(TraitError, match="sun_azimuth"):
        p.sun_azimuth = float("nan")
    assert p.sun_elevation == 30.0 and p.sun_azimuth == -45.0
    height.max = 120  # a value the control allows but the trait refuses
    height.value = 100
    assert p.sun_elevation == 30.0 and height.value == 30.0
    assert "sun_elevation" in widget.panel.message_line.value
    height.max = 90
    # the picture follows: a low sun from the other side lights the field differently
    p.shadows = True
    a = widget.scene.render_at(SIZE, antialias=False)
    p.sun_azimuth, p.sun_elevation = 135.0, 10.0
    b = widget.scene.render_at(SIZE, antialias=False)
    assert np.abs(a[..., :3].astype(int) - b[..., :3].astype(int)).mean() > 2.0


def test_time_scale_steps_per_frame_capped(widget):
    widget.time_scale = 10.0
    assert widget.steps_per_frame <= gw.widget.MAX_STEPS_PER_FRAME
    widget.time_scale = 0.0
    assert widget.steps_per_frame == 0


def test_bad_values_raise_and_widget_keeps_working(widget, tmp_path):
    p = widget.params
    before = p.gravity
    for bad in (float("nan"), float("inf"), -1.0, 1e9, "heavy"):
        with pytest.raises(TraitError, match="gravity"):
            p.gravity = bad
    assert p.gravity == before and widget.panel.sliders["gravity"].value == before
    with pytest.raises(TraitError, match="wind_field"):
        p.wind_field = "tornado"
    with pytest.raises(TraitError, match="time_scale"):
        widget.time_scale = -1
    with pytest.raises(ValueError, match="blades"):
        widget.blade_count = 0
    with pytest.raises(ValueError, match="size"):
        widget.save_png(tmp_path / "x.png", size=(0, 5))
    # A value the control allows but the trait refuses (as if the slider's range
    # were wider): the control snaps back and the message line says why.
    s = widget.panel.sliders["gravity"]
    s.max = 100
    s.value = 80
    assert p.gravity == before and s.value == before
    assert "gravity" in widget.panel.message_line.value
    # A huge number typed into a readout is clamped by the slider itself.
    widget.panel.sliders["wind_speed"].value = 1e12
    assert p.wind_speed == widget.panel.sliders["wind_speed"].max
    # ...and a later valid change still applies, and drawing still works.
    p.gravity = 12.5
    assert widget.panel.sliders["gravity"].value == 12.5
    _resize(widget)
    widget.view.draw()
    img = widget.scene.render_at(SIZE)
    assert grass_mask(img).mean() > 0.1


def test_bad_constructor_args():
    with pytest.raises(ValueError, match="size"):
        gw.GrassWidget(blades=16, size=(0, 0))
    with pytest.raises(TypeError, match="params"):
        gw.GrassWidget(blades=16, size=SIZE, params={"gravity": 1})
    with pytest.raises(ValueError, match="blades"):
        gw.GrassWidget(blades=0, size=SIZE)
    with pytest.raises(TypeError, match="blades"):
        gw.GrassWidget(blades="many", size=SIZE)


def test_shared_params_object():
    p = gw.GrassParams(wind_strength=42.0)
    w = gw.GrassWidget(blades=256, size=SIZE, params=p)
    try:
        assert w.params is p and w.scene.params is p
        assert w.panel.sliders["wind_strength"].value == 42.0
    finally:
        w.close()
    # closing unhooks the controls: p keeps working on its own
    p.wind_strength = 3.0
    assert w.panel.sliders["wind_strength"].value == 42.0


def test_play_pause_step_reset(widget):
    f = widget.scene.field
    _resize(widget)
    assert widget.playing
    widget.view.draw()  # a frame while playing advances steps_per_frame steps
    assert f.step_count == widget.steps_per_frame
    widget.pause()
    assert widget.panel.play_button.description == "Play"
    n = f.step_count
    widget.view.draw()
    assert f.step_count == n
    widget.panel.step_button.click()
    assert f.step_count == n + max(1, widget.steps_per_frame) and not widget.playing
    widget.step(5)
    assert f.step_count == n + max(1, widget.steps_per_frame) + 5
    widget.panel.reset_blades_button.click()
    assert f.step_count == 0
    widget.panel.play_button.click()
    assert widget.playing and widget.panel.play_button.description == "Pause"


def test_orbit_without_picking_and_keys(widget, monkeypatch):
    """Pointer events from the canvas reach the OrbitController; no pick readback."""
    _resize(widget)
    renderer = widget.scene.renderer
    calls = []
    monkeypatch.setattr(renderer, "get_pick_info", lambda pos: calls.append(pos) or {})
    cam = widget.scene.camera
    p0 = np.array(cam.world.position)
    base = dict(modifiers=(), ntouches=0, touches={}, timestamp=0)  # jupyter-rfb's current event format
    widget.view.events(dict(type="pointer_down", x=80, y=60, button=1, buttons=(1,), **base))
    for i in range(1, 11):
        widget.view.events(dict(type="pointer_move", x=80 + 6 * i, y=60, button=0, buttons=(1,), **base))
    widget.view.events(dict(type="pointer_up", x=140, y=60, button=1, buttons=(), **base))
    for _ in range(60):  # let the damped action converge
        widget.controller.tick()
    moved = np.linalg.norm(np.array(cam.world.position) - p0)
    assert moved > 0.5
    # orbiting keeps the distance to the target
    t = widget.controller.target
    assert np.isclose(np.linalg.norm(p0 - t), np.linalg.norm(np.array(cam.world.position) - t), rtol=1e-3)
    assert calls == []
    widget.view.on_key({"type": "key_down", "key": "r", "modifiers": ()})
    assert np.allclose(cam.world.position, p0, atol=1e-5)
    widget.view.on_key({"type": "key_down", "key": " ", "modifiers": ()})
    assert not widget.playing
    widget.view.on_key({"type": "key_down", "key": "s", "modifiers": ()})
    assert widget.scene.field.step_count > 0
    widget.view.on_key({"type": "key_down", "key": " ", "modifiers": ("Control",)})  # not ours
    assert not widget.playing


def test_stats_line(widget):
    _resize(widget)
    widget.view.draw()
    widget.view.refresh_stats()
    s = widget.stats
    assert s["blades"] == 1024 and s["visible"] is not None and 0 <= s["visible"] <= 1024
    line = widget.panel.stats_line.value
    # never "0.0 frames/s" (the number alone: "10.0 frames/s" holds that text too)
    assert "blades drawn" in line and not re.search(r"(?<![\d.])0\.0 frames/s", line), line
    if s["fps"] < 0.05:  # a frame was sent and no browser confirmed it: said in words, no "real time"
        assert "waiting for frames" in line and "real time" not in line, line
    else:  # frames drawn (nothing sent)
        assert f"{s['fps']:.1f} frames/s" in line, line


def test_stats_say_how_old_they_are_and_a_view_at_rest_says_so(widget):
    """Issue 37, item 4, kernel engine: a drawn frame's stats are fresh; a view out of sight
    (jupyter-rfb's visibility trait, as the page sets it) rests, and its stats and status line
    say so, also after a change made meanwhile (not drawn); back on screen, fresh again."""
    from grasswidget import compat

    _resize(widget)
    widget.pause()
    widget.view.draw()
    widget.view.refresh_stats()
    s = widget.stats
    assert 0.0 <= s["frame_age_s"] < 60.0 and not s["stale"] and not s["at_rest"] and not s["waiting"]
    assert "at rest" not in widget.panel.stats_line.value and "ago" not in widget.panel.stats_line.value
    compat.set_view_visibility(widget.canvas, True)
    compat.set_view_visibility(widget.canvas, False)  # scrolled out of sight
    s = widget.stats
    assert s["at_rest"] and s["stale"] and s["frame_age_s"] >= 0.0
    widget.params.cull_orientation = not widget.params.cull_orientation  # from a cell: nothing is drawn
    line = widget.panel.stats_line.value
    assert widget.stats["stale"] and line.startswith("<small>paused, out of sight") and " ago" in line, line
    compat.set_view_visibility(widget.canvas, True)
    widget.view.draw()  # back on screen: jupyter-rfb asks for a frame
    s = widget.stats
    assert not s["at_rest"] and not s["stale"]


def test_blade_count_slider_rebuilds(widget):
    cam_before = np.array(widget.scene.camera.world.position)
    widget.panel.blade_slider.value = 512  # fewer blades: at once
    assert widget.blade_count == 512 and widget.scene.field.count == 512
    # more blades than the measured frame rate allows at target_fps (here: none measured yet) ask first
    widget.panel.blade_slider.value = 2048
    assert widget.blade_count == 512 and widget.panel.blade_control.pending == 2048
    widget.panel.blade_control.apply_button.click()
    assert widget.blade_count == 2048 and widget.scene.field.count == 2048
    assert np.allclose(widget.scene.camera.world.position, cam_before)
    widget.blade_count = 512
    assert widget.panel.blade_slider.value == 512 and widget.scene.field.count == 512
    _resize(widget)
    widget.view.draw()


def test_save_png_from_code_and_button(widget, tmp_path, monkeypatch):
    import imageio.v3 as iio

    path = widget.save_png(tmp_path / "shot.png", size=(200, 150))
    with open(path, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    img = iio.imread(path)
    assert img.shape[:2] == (150, 200)
    assert grass_mask(img).mean() > 0.1
    # default: twice the view; the button writes into output/ under the working directory (created)
    monkeypatch.chdir(tmp_path)
    widget.panel.save_button.click()
    assert not list(tmp_path.glob("grass-*.png"))
    pngs = sorted((tmp_path / "output").glob("grass-*.png"))
    assert len(pngs) == 1, widget.panel.message_line.value
    assert iio.imread(pngs[0]).shape[:2] == (2 * SIZE[1], 2 * SIZE[0])
    assert pngs[0].name in widget.panel.file_line.value
    widget.panel.png_scale.value = 1
    widget.panel.save_button.click()
    assert len(sorted((tmp_path / "output").glob("grass-*.png"))) == 2
    # save_png() without a path: the same folder, a new name
    own = widget.save_png(size=(64, 48))
    assert Path(own).parent == tmp_path / "output" and iio.imread(own).shape[:2] == (48, 64)
    assert len(sorted((tmp_path / "output").glob("grass-*.png"))) == 3


def test_save_animation_gif_deterministic(widget, tmp_path):
    import imageio.v3 as iio

    p = widget.params
    p.wind_strength = 40.0
    widget.scene.step(10)
    state = widget.scene.field.read_state()
    steps = widget.scene.field.step_count
    a = widget.save_animation(tmp_path / "a.gif", seconds=0.5, fps=12, size=(96, 72), progress=False)
    b = widget.save_animation(tmp_path / "b.gif", seconds=0.5, fps=12, size=(96, 72), progress=False)
    fa, fb = iio.imread(a, index=None), iio.imread(b, index=None)
    assert fa.shape[0] == 6 and fa.shape[1:3] == (72, 96)
    assert np.array_equal(fa, fb)
    # the live state is back where it was
    after = widget.scene.field.read_state()
    assert np.array_equal(after["v2"], state["v2"]) and widget.scene.field.step_count == steps
    assert not np.array_equal(fa[0], fa[-1])  # the wind moved the grass


def test_export_argument_errors(widget, tmp_path):
    from grasswidget.tools.export import plan_animation, save_animation

    s = widget.scene
    with pytest.raises(ValueError, match="path"):
        save_animation(s, tmp_path / "x.avi", 1, 10)
    with pytest.raises(ValueError, match="seconds"):
        save_animation(s, tmp_path / "x.gif", 0, 10)
    with pytest.raises(ValueError, match="fps"):
        save_animation(s, tmp_path / "x.gif", 1, float("nan"))
    with pytest.raises(TypeError, match="fps"):
        save_animation(s, tmp_path / "x.gif", 1, "fast")
    with pytest.raises(ValueError, match="size"):
        save_animation(s, tmp_path / "x.gif", 1, 10, size=(-1, 10))
    with pytest.raises(ValueError, match="even"):
        save_animation(s, tmp_path / "x.mp4", 1, 10, size=(101, 80))
    with pytest.raises(FileNotFoundError):
        save_animation(s, tmp_path / "nope" / "x.gif", 1, 10)
    with pytest.raises(ValueError, match="dt"):
        plan_animation(0.05, 1, 100)
    plan = plan_animation(1 / 120, 2, 24)
    assert plan == dict(frames=48, steps_per_frame=5, speed=1.0, fps=24.0)


def test_save_animation_mp4(widget, tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    import imageio.v3 as iio

    path = widget.save_animation(tmp_path / "a.mp4", seconds=0.25, fps=20, size=(96, 64), progress=False)
    frames = iio.imread(path, index=None, plugin="pyav") if _has_pyav() else _read_mp4(path)
    assert len(frames) == 5 and frames[0].shape[:2] == (64, 96)


def _has_pyav():
    try:
        import av  # noqa: F401

        return True
    except ImportError:
        return False


def _read_mp4(path):
    import imageio.v2 as iio2

    with iio2.get_reader(path, format="FFMPEG") as r:
        return [f for f in r]


def _gpu_bytes():
    import wgpu

    gc.collect()
    d = wgpu.diagnostics.object_counts.get_dict()
    return sum(v.get("resource_mem", 0) for k, v in d.items() if k in ("Buffer", "Texture")), d["Buffer"]["count"]


def test_recreating_does_not_grow_gpu_memory():
    import resource

    def cycle():
        w = gw.GrassWidget(blades=4096, size=SIZE)
        _resize(w)
        w.view.draw()
        w.close()

    cycle()
    mem0, n0 = _gpu_bytes()
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for _ in range(20):
        cycle()
    mem1, n1 = _gpu_bytes()
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    field_bytes = 4096 * 80
    # 20 leaked fields would be >= 20 * field_bytes; allow less than two.
    assert mem1 - mem0 < 2 * field_bytes, (mem0, mem1, n0, n1)
    assert n1 - n0 < 20, (n0, n1)
    assert (rss1 - rss0) * 1024 < 300e6  # generous: ru_maxrss is in KiB on Linux


def test_closed_widget_refuses_work(tmp_path):
    w = gw.GrassWidget(blades=64, size=SIZE)
    w.close()
    w.close()  # twice is fine
    assert w.scene is None
    with pytest.raises(RuntimeError, match="closed"):
        w.save_png(tmp_path / "x.png")


@pytest.mark.parametrize("backend", ["kernel", "browser"])
def test_a_closed_widget_still_reads_its_last_stats_and_camera(backend):
    """Reading a closed widget's data is harmless, in both engines alike: ``stats`` and ``camera_state``
    give what the view had when it closed (not a raw AttributeError from the released scene); setting
    the camera raises WidgetClosedError."""
    w = gw.GrassWidget(blades=gw.Blades.on_plane(96, seed=3), size=SIZE, backend=backend)
    w.camera_state = {"position": (1.0, 2.0, 6.0), "target": (0.5, 0.2, 0.0), "fov_deg": 40.0}
    before = w.camera_state
    w.close()
    assert w.stats["blades"] == 96
    after = w.camera_state
    assert np.allclose(after["position"], before["position"]) and np.allclose(after["target"], before["target"])
    assert after["fov_deg"] == pytest.approx(before["fov_deg"])
    with pytest.raises(gw.WidgetClosedError):
        w.camera_state = {"fov_deg": 30.0}


def test_preset():
    if not hasattr(gw.GrassScene, "preset"):
        with pytest.raises(NotImplementedError, match="preset"):
            gw.GrassWidget(blades=256, size=SIZE, preset="cis565")
        return
    w = gw.GrassWidget(blades=512, size=SIZE, preset="cis565")
    try:
        assert w.scene.field.count == 512 and w.scene.size == SIZE
        # cis565: camera at (0, 1, 10) looking at (0, 1, 0): orbit around a point on that axis
        assert np.allclose(w.controller.target[[0, 1]], (0, 1), atol=1e-3)
        w.blade_count = 1024  # rebuilding keeps the preset
        assert w.scene.field.count == 1024 and getattr(w.scene, "preset_name", "cis565") == "cis565"
    finally:
        w.close()


def test_close_with_pending_uploads_leaves_other_scenes_working():
    """Closing destroys buffers that may still have an upload queued in pygfx's
    global registry (reset() queues one); the next render elsewhere must not touch them."""
    a = gw.GrassWidget(blades=256, size=SIZE)
    a.reset_blades()
    a.params.cull_frustum = False
    a.close()
    b = gw.GrassWidget(blades=256, size=SIZE)
    try:
        _resize(b)
        b.view.draw()
        assert grass_mask(b.scene.render_at(SIZE)).mean() > 0.05
    finally:
        b.close()
