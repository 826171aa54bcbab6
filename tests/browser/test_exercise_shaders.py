"""The browser engine runs a student's functions too: the WGSL it is sent (without a browser).

With ``function_overrides`` every shader of the browser engine that defines the replaced
functions (the simulation, both culling passes, occlusion's second pass, the inspector; the ribbons
and the sky include the blade math too, unused there) carries the
student's code instead of the stock definitions and still compiles; the others are untouched.
The engine in a real page is tested with the rest of the browser engine (tests/browser).
"""

import pytest

import grasswidget as gw
from grasswidget.browser.engine_widget import BrowserEngineWidget
from grasswidget.browser.browser_wgsl import BrowserShaders
from grasswidget.core.wgsl_overrides import OVERRIDE_MARKER


def _codes(shaders):
    occ = shaders["occlusion"]
    return {"simulate": shaders["simulate"], "cull_count": shaders["cull_count"], "cull": shaders["cull"],
            "occlusion cull": occ["cull"], "inspect": shaders["inspect"], "reset_args": shaders["reset_args"],
            "blades": shaders["blades"][0], "sky_ground": shaders["sky_ground"]}


@pytest.mark.parametrize("name", ["forces", "culling"])
def test_browser_shaders_carry_the_students_functions_and_compile(name):
    from grasswidget.gpu.adapter import ensure_device

    ex = gw.exercise(name)
    overrides = ex.overrides(ex.solution())
    view = BrowserEngineWidget(gw.Blades.on_plane(64), size=(96, 72), function_overrides=overrides)
    stock = _codes(BrowserShaders.all())
    mine = _codes(view.shaders)
    device = ensure_device()
    for key in ("simulate", "cull_count", "cull", "occlusion cull", "inspect", "blades", "sky_ground"):
        code = mine[key]["code"]
        assert OVERRIDE_MARKER in code and code.endswith(overrides.code + "\n"), key
        for fn in ex.functions:
            assert code.count(f"fn {fn}(") == 1, (key, fn)
        assert mine[key]["bindings"] == stock[key]["bindings"], key
        device.create_shader_module(code=code)  # naga validates the whole module
    assert mine["reset_args"] == stock["reset_args"]  # no blade math there


def test_a_browser_widget_refuses_other_functions_later():
    ex = gw.exercise("forces")
    overrides = ex.overrides(ex.solution())
    w = gw.GrassWidget(blades=64, size=(96, 72), backend="browser", function_overrides=overrides)
    try:
        assert w.function_overrides is overrides and w.view.function_overrides is overrides
        w.set_function_overrides(overrides)  # the same: fine
        with pytest.raises(gw.GrassValueError, match="when the widget is made"):
            w.set_function_overrides(None)
    finally:
        w.close()
