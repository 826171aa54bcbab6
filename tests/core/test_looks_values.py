"""The looks' values, decided once in Python for both engines (pure: no GPU).

The look traits refuse bad values naming their range; the sky/ground values put the
soil under the field, darker the denser the grass; the blade material's values carry
the params' looks and refuse what the layout does not know.
"""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import engine_inputs
from grasswidget.core.params import LOOK_TRAITS
from grasswidget.core.uniform_layouts import GRASS_MATERIAL_LAYOUT, SKY_GROUND_LAYOUT


@pytest.mark.parametrize("name, bad", [("fog_density", -0.1), ("patch_size", 0.0), ("dryness", 1.5),
                                       ("translucency", float("nan")), ("color_variation", 2)])
def test_look_traits_refuse_bad_values_naming_the_range(name, bad):
    p = gw.GrassParams()
    before = getattr(p, name)
    with pytest.raises(ValueError, match=name):
        setattr(p, name, bad)
    assert getattr(p, name) == before


def test_sky_ground_values_fill_the_layout_and_darken_the_soil_under_dense_grass():
    sparse = gw.Blades.on_plane(50, size=10.0, seed=2)
    dense = gw.Blades.on_plane(20000, size=10.0, seed=2)
    params = gw.GrassParams(fog_density=0.07)
    values = engine_inputs.sky_ground_values(dense, 80.0, params)
    assert list(values) == [name for name, _ in SKY_GROUND_LAYOUT]
    assert values["fog_density"] == 0.07 and values["far_distance"] == 80.0 and values["show_ground"] == 1
    # leaf area index by hand: one-sided area 2 w h per blade over the field's area
    (cx, cz), (hx, hz) = engine_inputs.field_rectangle(dense)
    leaf = np.sum(2 * dense.width * dense.height) / (4 * hx * hz)
    assert values["cover"] == pytest.approx(1 - np.exp(-leaf / 4))
    assert engine_inputs.field_cover(sparse) < 0.5 < values["cover"]
    assert engine_inputs.sky_ground_values(dense, None, show_ground=False)["show_ground"] == 0
    assert engine_inputs.sky_ground_values(dense, None)["fog_density"] == gw.GrassParams().fog_density


def test_material_values_carry_the_params_looks():
    params = gw.GrassParams(color_variation=0.2, patch_size=12.0, dryness=0.7, translucency=0.0, fog_density=0.0,
                            blade_shape="fold")
    values = engine_inputs.material_values(params, root_color="#000000")
    assert set(values) == {name for name, _ in GRASS_MATERIAL_LAYOUT}
    assert {k: values[k] for k in LOOK_TRAITS} == {k: float(getattr(params, k)) for k in LOOK_TRAITS}
    assert values["root_color"] == (0.0, 0.0, 0.0, 1.0)
    assert np.isclose(np.linalg.norm(values["light_direction"][:3]), 1.0)
    assert values["blade_shape"] == int(gw.core.enums.BladeShape.from_label("fold"))
    with pytest.raises(gw.GrassValueError, match="tip_colour"):
        engine_inputs.material_values(params, tip_colour="#ffffff")


def test_export_filter_is_pygfx_mitchell_supersampling():
    """The browser's export filter: pygfx's Mitchell SSAA at scale 2, whose 12-tap form
    (pygfx's ssaa.wgsl) pairs taps: 0.269867 for the 2 x 2 nearest pairs, -0.009934 for
    a near pair times a far one."""
    f = engine_inputs.export_filter(2)
    w = np.array(f["weights"])
    assert f["factor"] == 2 and f["first"] == -3 and len(w) == 8 and w.sum() == pytest.approx(1.0)
    near, far = w[2] + w[3], w[0] + w[1]
    assert near * near == pytest.approx(0.269867, abs=1e-3)
    assert near * far == pytest.approx(-0.009934, abs=2e-4)
    assert engine_inputs.export_filter(1) == {"factor": 1, "first": 0, "weights": [1.0]}
    for bad in (0, 5, 2.0, True):
        with pytest.raises(gw.GrassValueError, match="factor"):
            engine_inputs.export_filter(bad)
