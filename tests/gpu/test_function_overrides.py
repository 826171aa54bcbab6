"""GrassField.set_function_overrides: user WGSL in every compute shader that holds the blade math.

The simulation steps with it, the blade inspector draws its forces, None gives the stock
physics back, and code that does not compile is refused with the user's line while the
functions in force stay.
"""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref

DOUBLE_WIND = ("return W * (fd * fr);", "return 2.0 * W * (fd * fr);")


def test_simulation_and_inspector_use_the_users_functions_and_none_restores_the_stock_ones():
    ex = gw.exercise("forces")
    scene = gw.GrassScene(gw.Blades.on_plane(256, seed=2), size=(96, 72))
    try:
        scene.params.wind_strength = 20.0
        start = scene.field.read_state()
        scene.inspect([0, 1, 2, 3])
        scene.render()
        stock_wind = np.array([b["wind"] for b in scene.read_inspected()])
        double = ex.overrides(ex.solution().replace(*DOUBLE_WIND))
        scene.field.set_function_overrides(double)
        scene.render()
        assert np.allclose([b["wind"] for b in scene.read_inspected()], 2 * stock_wind, rtol=1e-4)
        assert np.abs(stock_wind).max() > 1.0  # the comparison means something

        scene.step(1)
        moved = scene.field.read_state()
        expected = ref.simulate(start, scene.params, 1)
        assert np.abs(moved["v2"] - expected["v2"]).max() > 1e-4  # not the stock physics

        broken = ex.solution().replace(*DOUBLE_WIND).replace("let fr = dot(v2 - v0, up) / height;",
                                                             "let fr = dot(v2 - v0, up) / heigth;")
        with pytest.raises(gw.ExerciseShaderError) as info:
            scene.field.set_function_overrides(ex.overrides(broken))
        assert info.value.line == broken.split("\n").index("    let fr = dot(v2 - v0, up) / heigth;") + 1
        assert scene.field.function_overrides is double  # still in force

        scene.field.set_function_overrides(None)
        scene.field.write_state(start)
        scene.field.step_count = 0
        scene.step(1)
        back = scene.field.read_state()
        h = start["height"][:, None]
        assert (np.abs(back["v2"] - expected["v2"]) / h).max() < 1e-5
    finally:
        scene.release()
