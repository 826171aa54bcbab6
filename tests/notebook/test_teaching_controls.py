"""The widget's teaching row drives the scene: colour by, freeze culling, legend,
ctrl + click inspect with the inspected blade's numbers, Clear."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import teaching
from conftest import WIDGET_SIZE

pytest.importorskip("ipywidgets")
pytest.importorskip("jupyter_rfb")

SIZE = WIDGET_SIZE


def _pointer(kind, x, y, modifiers=(), button=1):
    """A pointer event in jupyter-rfb's current format ("type", "timestamp")."""
    return dict(type=kind, x=x, y=y, button=button, buttons=(1,) if kind != "pointer_up" else (),
                modifiers=modifiers, ntouches=0, touches={}, timestamp=0)


def _show(w):
    """What the browser sends when the view appears, then one frame."""
    w.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    w.pause()
    w.view.draw()


def _screen_of(camera, point):
    vp = np.asarray(camera.projection_matrix, np.float64) @ np.asarray(camera.view_matrix, np.float64)
    c = vp @ np.array([*point, 1.0])
    c = c / c[3]
    return (c[0] + 1) / 2 * SIZE[0], (1 - c[1]) / 2 * SIZE[1]


def test_colour_by_dropdown_and_legend(widget):
    dd = widget.panel.color_by_dropdown
    assert dd.options == ("natural", "lod", "cull") and dd.value == "natural"
    assert "natural" in widget.panel.legend_line.value
    dd.value = "cull"
    assert widget.params.color_by == "cull"
    for color in gw.CULL_COLORS.values():
        assert color in widget.panel.legend_line.value
    widget.params.color_by = "lod"
    assert dd.value == "lod"
    assert all(c in widget.panel.legend_line.value for c in gw.LOD_COLORS)
    with pytest.raises(ValueError, match="color_by must be one of"):
        widget.params.color_by = "rainbow"
    assert dd.value == "lod" and widget.params.color_by == "lod"
    _show(widget)  # still draws


def test_freeze_checkbox_freezes_the_scene_and_orbiting_keeps_the_culled_set(widget):
    _show(widget)
    cb = widget.panel.freeze_checkbox
    assert not cb.value and not widget.scene.culling_frozen
    cb.value = True
    assert widget.culling_frozen and widget.scene.culling_frozen
    assert widget.scene.field.frustum_lines is not None
    widget.view.draw()
    kept = widget.scene.field.read_visible()
    cam = widget.scene.camera
    pos = np.array(cam.world.position)
    widget.view.events(_pointer("pointer_down", 80, 60))
    for i in range(1, 8):
        widget.view.events(_pointer("pointer_move", 80 + 10 * i, 60 - 3 * i, button=0))
    widget.view.events(_pointer("pointer_up", 150, 39))
    for _ in range(30):
        widget.controller.tick()
    assert np.linalg.norm(np.array(cam.world.position) - pos) > 0.3  # a plain drag orbits
    widget.view.draw()
    assert np.array_equal(widget.scene.field.read_visible(), kept)
    # a new blade count keeps culling frozen at the same camera copy
    frozen = widget.scene.field.frozen_camera
    widget.set_blades(2000)
    assert widget.scene.culling_frozen and widget.scene.field.frozen_camera is frozen
    widget.culling_frozen = False
    assert not cb.value and not widget.scene.culling_frozen
    widget.view.draw()


def test_ctrl_click_inspects_the_blade_under_the_pointer():
    # 36 blades 1.5 m apart: each pixel shows at most one blade
    xs, zs = np.meshgrid(np.arange(6) * 1.5 - 3.75, np.arange(6) * 1.5 - 3.75)
    n = xs.size
    blades = gw.Blades(v0=np.c_[xs.ravel(), np.zeros(n), zs.ravel()], up=np.tile([0.0, 1, 0], (n, 1)),
                       orientation=np.zeros(n), height=np.full(n, 1.6), width=np.full(n, 0.3),
                       stiffness=np.linspace(6, 12, n))
    params = gw.GrassParams(blade_shape="quad", wind_strength=0.0, cull_orientation=False)
    w = gw.GrassWidget(blades=blades, size=SIZE, params=params)
    try:
        _show(w)
        assert w.panel.inspect_line.value.count("ctrl + click") == 1
        cam = w.scene.camera
        pos = np.array(cam.world.position)
        for k in (7, 21):
            state = w.scene.field.read_state()
            mid = 0.25 * state["v0"][k] + 0.5 * state["v1"][k] + 0.25 * state["v2"][k]
            x, y = _screen_of(cam, mid)
            w.view.events(_pointer("pointer_down", x, y, ("Control",)))
            w.view.events(_pointer("pointer_up", x, y, ("Control",)))
            assert w.inspected == (k,)
            assert w.scene.inspected == (k,)
            w.view.draw()  # the numbers come with the next frame (one small readback)
            line = w.panel.inspect_line.value
            assert f"blade {k}:" in line and "height 1.60 m" in line
            assert f"stiffness {blades.stiffness[k]:.2f}" in line
            assert "gravity 10.10" in line  # |(0, -9.8, 0) + 0.25 * 9.8 * f| = 10.10 m/s^2
        for _ in range(30):
            w.controller.tick()
        assert np.allclose(cam.world.position, pos)  # ctrl + click does not orbit
        # a click on the sky inspects nothing new
        w.view.events(_pointer("pointer_down", SIZE[0] / 2, 2, ("Control",)))
        w.view.events(_pointer("pointer_up", SIZE[0] / 2, 2, ("Control",)))
        assert w.inspected == (21,)
        # the panel's numbers follow the GPU at each stats refresh
        w.step(30)
        w.view.draw()
        w.view.refresh_stats()
        assert "blade 21:" in w.panel.inspect_line.value
        w.panel.clear_inspect_button.click()
        assert w.inspected == () and w.scene.inspected == ()
        assert "ctrl + click" in w.panel.inspect_line.value
    finally:
        w.close()


def test_inspect_from_code_and_bad_input(widget):
    _show(widget)
    widget.inspect([3, 9])
    assert widget.inspected == (3, 9)
    rows = widget.read_inspected()  # renders first: nothing was drawn since inspect
    assert [r["id"] for r in rows] == [3, 9] and np.all(np.isfinite(rows[0]["v2"]))
    widget.view.draw()
    for mine, theirs in zip(rows, widget.scene.read_inspected()):
        assert mine.keys() == theirs.keys()
        assert all(np.allclose(mine[k], theirs[k]) for k in mine)
    assert "blade 3:" in widget.panel.inspect_line.value and "blade 9:" in widget.panel.inspect_line.value
    for bad, match in [(list(range(65)), "at most 64"), ([1024], r"\[0, 1023\]"), ([0.5], "integers")]:
        with pytest.raises(ValueError, match=match):
            widget.inspect(bad)
        assert widget.inspected == (3, 9)
    widget.view.draw()  # keeps running
    widget.inspect([])
    assert widget.inspected == ()
    assert teaching.MAX_INSPECTED == 64


def test_browser_widget_teaching_views_without_a_browser():
    """The browser engine's teaching views, the Python side (the page: tests/e2e/
    test_browser_teaching.py): freezing sends the frozen camera in u_cull and its frustum
    as line data; inspect sends the ids; bad ids change nothing; read_inspected with no
    browser answering names the browser view; ctrl + click picks the blade on the ray."""
    import struct

    from grasswidget.browser.uniforms import CULL_LAYOUT
    from grasswidget.core.uniform_layouts import INSPECT_LAYOUT, offsets
    from grasswidget.errors import BrowserTimeoutError

    w = gw.GrassWidget(256, backend="browser", size=SIZE, pixel_ratio=1)
    try:
        bv = w.view.engine_widget
        w.culling_frozen = True
        frozen = w.view.frozen_camera
        assert frozen.viewport_size == (float(SIZE[0]), float(SIZE[1]))
        cam = bv.camera
        want = teaching.camera_view_proj(cam["position"], cam["target"], cam["fov_deg"], cam["near"], cam["far"],
                                         SIZE[0] / SIZE[1])
        assert np.allclose(frozen.view_proj, want)
        at = offsets(CULL_LAYOUT)
        assert struct.unpack_from("<i", bv.cull_uniform, at["frozen"][0])[0] == 1
        sent = np.frombuffer(bv.cull_uniform, np.float32, 16, at["frozen_view_proj"][0]).reshape(4, 4)
        assert np.allclose(sent.T, want, rtol=1e-6, atol=1e-6)  # column-major in WGSL
        lines = np.frombuffer(bv.frustum_lines, np.float32).reshape(24, 3)
        assert np.allclose(lines, teaching.frustum_segments(want), atol=1e-5)
        assert "not available" not in w.panel.message_line.value
        w.culling_frozen = False
        assert bv.frustum_lines == b"" and struct.unpack_from("<i", bv.cull_uniform, at["frozen"][0])[0] == 0

        w.inspect([5, 9])
        assert w.inspected == (5, 9) and bv.inspected == [5, 9]
        ids = np.frombuffer(bv.inspect_uniform, np.uint32, 3, offsets(INSPECT_LAYOUT)["ids"][0])
        assert ids.tolist() == [5, 9, 0]
        with pytest.raises(ValueError, match="at most 64"):
            w.inspect(list(range(65)))
        assert w.inspected == (5, 9)
        with pytest.raises(BrowserTimeoutError, match="browser view"):
            w.read_inspected(timeout=0.5)
        w.inspect([])
        assert w.read_inspected() == []

        # ctrl + click: the browser sends the pointer's ray; the blade it passes through is inspected
        b = bv.blades
        k = 17
        mid = b.v0[k] + 0.5 * b.height[k] * b.up[k]
        eye = mid + np.array([0.0, 1.0, 6.0])
        bv.handle_message({"type": "pick", "origin": eye.tolist(), "direction": (mid - eye).tolist()})
        assert w.inspected == (k,)
        bv.handle_message({"type": "pick", "origin": [0, 50, 0], "direction": [0, 1, 0]})  # the sky: nothing
        assert w.inspected == (k,)
        w.params.color_by = "cull"
        assert "not available" not in w.panel.message_line.value
    finally:
        w.close()


def test_pick_blade_on_ray_is_the_nearest_blade_the_ray_passes():
    v0 = np.array([[0.0, 0, 0], [0.0, 0, -2.0], [3.0, 0, 0]])
    up = np.tile([0.0, 1, 0], (3, 1))
    h = np.array([1.0, 1.0, 1.0])
    width = np.full(3, 0.05)
    # along -z at half height: passes blades 0 and 1, the nearest (0) is picked
    assert teaching.pick_blade_on_ray(v0, up, h, width, (0, 0.5, 5), (0, 0, -1)) == 0
    assert teaching.pick_blade_on_ray(v0, up, h, width, (0, 0.5, -5), (0, 0, 1)) == 1
    assert teaching.pick_blade_on_ray(v0, up, h, width, (0, 1.5, 5), (0, 0, -1)) is None  # above the tips
    assert teaching.pick_blade_on_ray(v0, up, h, width, (3.03, 0.2, 5), (0, 0, -1)) == 2  # within its width
