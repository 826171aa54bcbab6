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
    widget.view.draw()
    assert "blade 3:" in widget.panel.inspect_line.value and "blade 9:" in widget.panel.inspect_line.value
    for bad, match in [(list(range(65)), "at most 64"), ([1024], r"\[0, 1023\]"), ([0.5], "integers")]:
        with pytest.raises(ValueError, match=match):
            widget.inspect(bad)
        assert widget.inspected == (3, 9)
    widget.view.draw()  # keeps running
    widget.inspect([])
    assert widget.inspected == ()
    assert teaching.MAX_INSPECTED == 64


def test_a_view_without_teaching_views_says_so_instead_of_failing():
    """The browser engine has no inspector or freeze culling yet: its GrassView raises
    FeatureNotAvailableError and the widget shows it on the message line instead of
    failing; colour-by works there."""
    from grasswidget.core.view_api import FeatureNotAvailableError

    w = gw.GrassWidget(256, backend="browser", size=SIZE)
    try:
        with pytest.raises(FeatureNotAvailableError, match="blade inspector is not available in the browser"):
            w.view.inspect([1])
        w.inspect([1])
        assert "the blade inspector is not available in the browser engine" in w.panel.message_line.value
        assert w.inspected == ()
        w.panel.message_line.value = ""
        w.culling_frozen = True
        assert "freeze culling is not available in the browser engine" in w.panel.message_line.value
        w.panel.message_line.value = ""
        w.params.color_by = "cull"
        assert w.panel.message_line.value == ""  # colour by works in both engines
    finally:
        w.close()
