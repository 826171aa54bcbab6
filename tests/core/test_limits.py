"""The numbers the physics takes (core/limits.py): what would overflow float32 is refused with the
input and its range named, the old value kept; every accepted extreme keeps the NumPy reference
finite; validate_finite puts non-finite blades back at rest; step counts above MAX_STEPS refused;
hold_interrupts holds Ctrl-C back and restores the handler."""

import os
import signal

import numpy as np
import pytest
import traitlets

import grasswidget as gw
from conftest import param_extremes
from grasswidget.core import reference as ref
from grasswidget.core.colliders import ColliderList, collider_array
from grasswidget.core.engine_inputs import sim_uniform_values
from grasswidget.core.limits import (MAX_BLADE_HEIGHT, MAX_BLADE_STIFFNESS, MAX_BLADE_WIDTH, MAX_COORDINATE,
                                     MAX_STEPS, StepsInterrupted, check_steps, hold_interrupts)


# ------------------------------------------------------------------ refused, with the range named


@pytest.mark.parametrize("name", ["wind_center", "gravity_center"])
@pytest.mark.parametrize("value", [(1e30, 0, 0), (0, -1.0000001e7, 0), (0, 0, 3e38)])
def test_centres_past_max_coordinate_are_refused_naming_the_range(name, value):
    p = gw.GrassParams(**{name: (1.0, 2.0, 3.0)})
    with pytest.raises(gw.ParameterError, match=rf"{name} must be .*each in \[-1e\+07, 1e\+07\]"):
        setattr(p, name, value)
    assert getattr(p, name) == (1.0, 2.0, 3.0)
    setattr(p, name, (MAX_COORDINATE, -MAX_COORDINATE, 0.0))  # the limit itself is accepted


@pytest.mark.parametrize("kwargs, what", [(dict(radius=1e30), "radius"), (dict(radius=1.0000001e7), "radius"),
                                          (dict(center=(1e30, 0, 0)), "center"), (dict(center=(0, 0, -2e7)), "center")])
def test_sphere_colliders_past_the_limit_are_refused(kwargs, what):
    with pytest.raises(gw.ParameterError, match=rf"{what} must be .*1e\+07"):
        gw.SphereCollider(**kwargs)
    ball = gw.SphereCollider(center=(1, 2, 3), radius=0.5)
    with pytest.raises(traitlets.TraitError, match=what):
        setattr(ball, what, kwargs[what])
    assert ball.as_vec4() == (1.0, 2.0, 3.0, 0.5)
    with pytest.raises(ValueError, match=rf"{what} .*1e\+07"):
        collider_array([((0, 0, 0), 1.0), (kwargs.get("center", (0, 0, 0)), kwargs.get("radius", 1.0))])


@pytest.mark.parametrize("row", [[1e30, 0, 0, 1], [0, 0, 0, 1e30], [0, -1.5e7, 0, 1.0]])
def test_collider_arrays_past_the_limit_are_refused_and_nothing_changes(row):
    colliders = ColliderList()
    colliders.set_array([[0, 0, 0, 1.0]])
    with pytest.raises(gw.GrassValueError, match=r"\[-1e\+07, 1e\+07\].*MAX_COORDINATE.*row 1 "):
        colliders.set_array([[0, 0, 0, 2.0], row])
    assert colliders.array().tolist() == [[0, 0, 0, 1.0]]


def test_blades_past_the_limits_are_refused_naming_the_array_and_range():
    ok = gw.Blades.on_plane(8, seed=1).rest_state()
    fields = dict(v0=ok["v0"], up=ok["up"], orientation=ok["orientation"], height=ok["height"],
                  width=ok["width"], stiffness=ok["stiffness"])
    cases = {"v0": (np.full((8, 3), 1e30), r"v0 .*\[-1e\+07, 1e\+07\]"),
             "height": (np.full(8, 1e30), r"height must be in \(0, 1000\] m"),
             "width": (np.full(8, 1e3), r"width must be in \(0, 100\] m"),
             "stiffness": (np.full(8, 1e38), r"stiffness must be in \(0, 1e\+06\] 1/s\^2")}
    for name, (bad, message) in cases.items():
        with pytest.raises(gw.GrassValueError, match=message):
            gw.Blades(**{**fields, name: bad})
    for kwargs, message in [(dict(height=(1.0, 1e30)), r"height .*<= 1000 m"), (dict(width=(0.1, 101)), "width"),
                            (dict(stiffness=(1, 2e6)), "stiffness"), (dict(size=1e30), r"size .*\(0, 2e\+07\]"),
                            (dict(size=10.0, reach=1e30), r"reach .*1e\+07")]:
        with pytest.raises(gw.GrassValueError, match=message):
            gw.Blades.on_plane(8, **kwargs)
    with pytest.raises(gw.GrassValueError, match=r"geometry positions must be in \[-1e\+07, 1e\+07\]"):
        gw.Blades.on_mesh((np.array([[0, 0, 0], [1e30, 0, 0], [0, 0, 1.0]]), np.array([0, 1, 2])), count=8)
    huge_angle = gw.Blades(**{**fields, "orientation": np.full(8, 3e38)})
    assert np.all(np.abs(huge_angle.orientation) <= np.pi + 1e-6)
    assert np.allclose(np.cos(huge_angle.orientation), np.cos(np.full(8, 3e38)), atol=1e-6)
    with pytest.raises(gw.GrassValueError, match=r"heights must be in \[-1e\+07, 1e\+07\]"):
        gw.Blades.on_heightmap(np.full((4, 4), 1e30), size=10.0, count=8)
    # The extremes themselves are accepted.
    gw.Blades(**{**fields, "height": np.full(8, MAX_BLADE_HEIGHT), "width": np.full(8, MAX_BLADE_WIDTH),
                 "stiffness": np.full(8, MAX_BLADE_STIFFNESS), "v0": np.full((8, 3), MAX_COORDINATE)})


def test_directions_of_any_finite_size_are_normalised_without_overflow():
    n = 4
    ok = gw.Blades.on_plane(n, seed=1).rest_state()
    huge = gw.Blades(v0=ok["v0"], up=np.tile([1e300, 1e300, 0.0], (n, 1)), orientation=ok["orientation"],
                     height=ok["height"], width=ok["width"], stiffness=ok["stiffness"])
    assert np.allclose(huge.up, [2 ** -0.5, 2 ** -0.5, 0], atol=1e-7)
    tiny = gw.Blades(v0=ok["v0"], up=np.tile([0.0, 1e-300, 0.0], (n, 1)), orientation=ok["orientation"],
                     height=ok["height"], width=ok["width"], stiffness=ok["stiffness"])
    assert np.allclose(tiny.up, [0, 1, 0])
    for direction, unit in [((1e300, -1e300, 0), (2 ** -0.5, -(2 ** -0.5), 0)), ((0, -1e-300, 0), (0, -1, 0))]:
        p = gw.GrassParams(gravity_direction=direction)
        assert np.allclose(sim_uniform_values(p, 4)["gravity_dir"][:3], unit)
        g = ref.environmental_gravity(p, np.zeros((2, 3)))
        assert np.allclose(g, np.array(unit) * p.gravity)


# ------------------------------------------------------------------ every accepted extreme stays finite


EXTREMES = param_extremes()


def test_the_extremes_cover_every_float_and_vector_trait():
    names = {n for n, _ in EXTREMES}
    assert {"wind_center", "gravity_center", "gravity_direction", "wind_strength", "dt", "stiffness_scale",
            "collision_gain", "collision_fade", "wind_radius", "wind_wavelength", "gravity"} <= names


@pytest.mark.parametrize("field", ["wave", "radial", "vortex", "noise"])
def test_every_numeric_parameter_at_either_end_keeps_the_reference_finite(field):
    blades = gw.Blades.on_plane(48, size=4.0, seed=3)
    spheres = np.array([[0.0, 0.5, 0.0, 1.0], [1.0, -MAX_COORDINATE + 2.0, 1.0, MAX_COORDINATE]])
    for name, value in EXTREMES:
        p = gw.GrassParams(wind_field=field, gravity_mode="point" if name == "gravity_center" else "direction")
        setattr(p, name, value)
        state = ref.simulate(blades.rest_state(), p, 6, colliders=spheres)
        for k in ("v1", "v2", "collision"):
            assert np.isfinite(state[k]).all(), (field, name, value, k)


# ------------------------------------------------------------------ the finite check


def test_validate_finite_resets_exactly_the_non_finite_blades():
    b = gw.Blades.on_plane(6, seed=2).rest_state()
    v1, v2 = b["v1"] + 0.1, b["v2"] + 0.2
    eta = np.full(6, 0.5)
    v1[1, 0], v2[2, 2], eta[3] = np.nan, np.inf, -np.inf
    out_v1, out_v2, out_eta, reset = ref.validate_finite(b["v0"], v1, v2, b["up"], b["height"], eta)
    assert reset.tolist() == [False, True, True, True, False, False]
    rest = b["v0"] + b["up"] * b["height"][:, None]
    assert np.allclose(out_v1[reset], rest[reset]) and np.allclose(out_v2[reset], rest[reset])
    assert np.all(out_eta[reset] == 0) and np.all(out_eta[~reset] == 0.5)
    assert np.allclose(out_v2[~reset], v2[~reset]) and np.allclose(out_v1[~reset], v1[~reset])


def test_a_nan_wind_leaves_the_reference_at_rest_and_a_normal_one_moves_it_again():
    blades = gw.Blades.on_plane(32, seed=4)
    p = gw.GrassParams(wind_field="custom")
    state = ref.simulate(blades.rest_state(), p, 10, user_wind=lambda pts, t: np.full_like(pts, np.nan))
    rest = blades.v0 + blades.up * blades.height[:, None]
    assert np.allclose(state["v2"], rest) and np.allclose(state["v1"], rest)
    state = ref.simulate(state, p, 10, user_wind=lambda pts, t: np.tile([20.0, 0, 0], (len(pts), 1)))
    assert np.isfinite(state["v2"]).all() and np.all(state["v2"][:, 0] > rest[:, 0] + 1e-3)


# ------------------------------------------------------------------ steps


def test_check_steps_takes_0_to_max_steps_and_names_the_limit():
    import numpy as np_

    assert check_steps(0) == 0 and check_steps(MAX_STEPS) == MAX_STEPS and check_steps(np_.int64(7)) == 7
    for n in (MAX_STEPS + 1, 2**40, -1, 1.0, True, "3", None):
        with pytest.raises(gw.GrassValueError, match=r"n \(number of steps\) must be an integer in \[0, 1,000,000\] "
                                                     r"\(MAX_STEPS"):
            check_steps(n)


def test_hold_interrupts_holds_ctrl_c_and_restores_the_handler(ctrl_c_enabled):
    before = signal.getsignal(signal.SIGINT)
    with hold_interrupts() as held:
        with hold_interrupts() as inner:
            assert inner is held  # nested holds share the outer one
        assert not held.hit
        os.kill(os.getpid(), signal.SIGINT)  # no KeyboardInterrupt here: recorded only
        assert held.hit
    assert signal.getsignal(signal.SIGINT) is before
    err = StepsInterrupted(12, 160)
    assert isinstance(err, KeyboardInterrupt) and not isinstance(err, Exception)
    assert (err.done, err.requested) == (12, 160) and "after 12 steps" in str(err)
