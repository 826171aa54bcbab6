"""Physics invariants of the NumPy reference (the spec)."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref

EXTREME = dict(gravity=50, wind_strength=200, stiffness_scale=0.01, dt=0.05, wind_speed=50, wind_wavelength=0.1)


def _check_invariants(state, b):
    v0, v1, v2, up = state["v0"], state["v1"], state["v2"], state["up"]
    for key in ("v1", "v2"):
        assert np.all(np.isfinite(state[key]))
    assert np.all(np.sum((v2 - v0) * up, axis=1) >= -1e-9), "tip below ground"
    length = ref.curve_length(v0, v1, v2)
    assert np.all(np.abs(length - b.height) <= 0.01 * b.height)


@pytest.mark.parametrize("params", [dict(), dict(wind_strength=120), EXTREME, dict(stiffness_scale=20, gravity=0)])
def test_invariants_after_1000_steps(params):
    b = gw.Blades.on_plane(400, seed=2)
    state = ref.simulate(b.rest_state(), gw.GrassParams(**params), 1000)
    _check_invariants(state, b)


def _lean(state):
    d = state["v2"] - state["v0"]
    return np.linalg.norm(d - state["up"] * np.sum(d * state["up"], axis=1)[:, None], axis=1)


def test_stiffer_blades_lean_less():
    b = gw.Blades.on_plane(400, seed=2)
    soft = ref.simulate(b.rest_state(), gw.GrassParams(wind_strength=20, stiffness_scale=0.5), 400)
    stiff = ref.simulate(b.rest_state(), gw.GrassParams(wind_strength=20, stiffness_scale=4), 400)
    assert _lean(stiff).mean() < 0.6 * _lean(soft).mean()
    # and within one field, the stiffer half leans less than the softer half
    lean = _lean(soft)
    order = np.argsort(b.stiffness)
    assert lean[order[-100:]].mean() < lean[order[:100]].mean()


def test_bending_grows_with_wind():
    b = gw.Blades.on_plane(200, seed=5)
    leans = [_lean(ref.simulate(b.rest_state(), gw.GrassParams(wind_strength=w), 300)).mean() for w in (0, 10, 40)]
    assert leans[0] < leans[1] < leans[2]


def test_return_to_rest_when_wind_stops():
    b = gw.Blades.on_plane(300, seed=9)
    calm = gw.GrassParams(wind_strength=0)
    rest = ref.simulate(b.rest_state(), calm, 1500)
    windy = ref.simulate(b.rest_state(), gw.GrassParams(wind_strength=60), 500)
    assert np.abs(windy["v2"] - rest["v2"]).max() > 0.3
    back = ref.simulate(windy, calm, 1500)
    assert np.abs(back["v2"] - rest["v2"]).max() < 1e-3


def test_ground_and_length_rules_directly():
    v0 = np.zeros((1, 3))
    up = np.array([[0.0, 1.0, 0.0]])
    v2 = np.array([[1.0, -0.5, 0.0]])
    g = ref.validate_ground(v0, v2, up)
    assert g[0, 1] == 0.0 and g[0, 0] == 1.0
    h = np.array([1.5])
    v1 = ref.validate_v1(v0, g, up, h)
    v1n, v2n = ref.validate_length(v0, v1, g, h)
    assert ref.curve_length(v0, v1n, v2n)[0] == pytest.approx(1.5)


def test_width_and_front_directions():
    up = np.array([[0.0, 1.0, 0.0]])
    t1 = ref.width_direction(up, np.array([0.3]))
    assert np.allclose(t1, [[np.cos(0.3), 0, np.sin(0.3)]])
    f = ref.front_direction(up, t1)
    assert abs(np.sum(f * t1)) < 1e-12 and abs(np.sum(f * up)) < 1e-12


def test_the_packages_all_is_its_modules_own():
    """``reference.__all__`` is derived from its modules' ``__all__``: exactly the package's public
    names (what its star imports bring, and ``safe_normalize``), each once."""
    import types

    from grasswidget.core import reference

    public = {name for name, value in vars(reference).items()
              if not name.startswith("_") and not isinstance(value, types.ModuleType) and name != "annotations"}
    assert len(reference.__all__) == len(set(reference.__all__))
    assert set(reference.__all__) == public
    for module in (reference.physics, reference.culling, reference.looks, reference.raster, reference.shadows):
        assert set(module.__all__) <= public
