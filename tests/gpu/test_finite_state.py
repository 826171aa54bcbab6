"""State that stays finite (issue 37, item 5), on this machine's adapter.

Every input a parameter or a collider accepts keeps every blade finite over many steps at
its extremes; what would overflow is refused with the range named (tests/core/
test_limits.py); a wind WGSL that returns NaN or inf leaves the blades at rest, finite,
with one warning; ``step(n)`` refuses n above MAX_STEPS and a long run can be interrupted
with the steps done counted.
"""

import os
import signal
import warnings

import numpy as np
import pytest

import grasswidget as gw
from conftest import param_extremes
from grasswidget.core import engine_inputs
from grasswidget.core import reference as ref
from grasswidget.core.limits import (MAX_BLADE_HEIGHT, MAX_BLADE_STIFFNESS, MAX_BLADE_WIDTH, MAX_COORDINATE, MAX_STEPS,
                                     NonFiniteStateWarning, StepsInterrupted)

BLADES = dict(count=512, size=6.0, seed=11)
STEPS = 40


def _finite(state):
    return all(np.isfinite(state[k]).all() for k in ("v1", "v2", "collision"))


def _at_rest(state, blades):
    rest = blades.v0 + blades.up * blades.height[:, None]
    return max(np.abs(state[k] - rest).max() for k in ("v1", "v2")) < 1e-5 * float(blades.height.max())


#: The extreme of every numeric input that moves blades, each the largest (or smallest) value
#: that its range accepts. Each case: GrassParams values, and colliders as (K, 4) rows.
EXTREMES = {
    "radial wind centre far": (dict(wind_field="radial", wind_center=(MAX_COORDINATE, 0, 0), wind_strength=200.0), None),
    "vortex wind centre far": (dict(wind_field="vortex", wind_center=(-MAX_COORDINATE, MAX_COORDINATE, MAX_COORDINATE),
                                    wind_strength=200.0), None),
    "radial wind tiny radius": (dict(wind_field="radial", wind_center=(0.01, 0, 0), wind_radius=0.01,
                                     wind_strength=200.0, wind_wavelength=0.1, wind_speed=50.0), None),
    "vortex wind huge radius": (dict(wind_field="vortex", wind_radius=1000.0, wind_wavelength=1000.0,
                                     wind_strength=200.0), None),
    "wave wind strongest": (dict(wind_field="wave", wind_strength=200.0, wind_speed=50.0, wind_wavelength=0.1,
                                 wind_direction=-360.0), None),
    "noise wind strongest": (dict(wind_field="noise", wind_strength=200.0, wind_speed=50.0, wind_wavelength=1000.0,
                                  wind_direction=360.0), None),
    "gravity point far": (dict(gravity_mode="point", gravity_center=(0, -MAX_COORDINATE, 0), gravity=50.0,
                               front_gravity=2.0), None),
    "gravity point at a root": (dict(gravity_mode="point", gravity_center=(0, 0, 0), gravity=50.0), None),
    "gravity direction huge": (dict(gravity_direction=(1e300, -1e300, 0), gravity=50.0), None),
    "gravity direction tiny": (dict(gravity_direction=(0, -1e-300, 1e-300), gravity=50.0), None),
    "stiffest, longest step": (dict(stiffness_scale=20.0, dt=0.05), None),
    "softest, shortest step": (dict(stiffness_scale=0.01, dt=1e-4, gravity=50.0), None),
    "huge collider": (dict(collision_gain=1e5), np.array([[0.0, 0.0, 0.0, MAX_COORDINATE]])),
    "collider far away": (dict(), np.array([[MAX_COORDINATE, 0.0, 0.0, 1.0]])),
    "collider huge, off-centre": (dict(collision_gain=0.0), np.array([[0.0, -MAX_COORDINATE + 1.0, 0.0, MAX_COORDINATE]])),
    "colliders tiny, gain and fade extreme": (dict(collision_gain=1e5, collision_fade=100.0),
                                              np.array([[0.0, 1.0, 0.0, 1e-6], [1.0, 0.5, 1.0, 2.0]])),
}


@pytest.mark.parametrize("case", sorted(EXTREMES))
def test_extreme_accepted_inputs_keep_every_blade_finite(case, fresh, blades):
    values, spheres = EXTREMES[case]
    resets = fresh.nonfinite_resets
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonFiniteStateWarning)  # the finite check must not be what saves it
        for name, value in values.items():
            setattr(fresh.params, name, value)
        if spheres is not None:
            fresh.colliders.set_array(spheres)
        fresh.step(STEPS)
        state = fresh.read_state()
    assert _finite(state), case
    assert fresh.nonfinite_resets == resets
    # Every blade keeps its length (the paper's validation still holds): finite and meaningful.
    length = ref.curve_length(state["v0"], state["v1"], state["v2"])
    assert np.allclose(length, blades.height, rtol=2e-3), case


def test_every_numeric_parameter_at_either_end_keeps_every_blade_finite_on_the_gpu(fresh):
    """All four built-in wind fields, each float/vector trait at each end of its range (gravity_center
    with gravity_mode 'point'), a huge ball and a small one in the field: float32 stays finite."""
    fresh.colliders.set_array([[0.0, 0.5, 0.0, 1.0], [1.0, -MAX_COORDINATE + 2.0, 1.0, MAX_COORDINATE]])
    extremes = param_extremes()
    assert len(extremes) > 40
    resets = fresh.nonfinite_resets
    bad = []
    defaults = gw.GrassParams()
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonFiniteStateWarning)
        for wind in ("wave", "radial", "vortex", "noise"):
            fresh.params.wind_field = wind
            for name, value in extremes:
                fresh.params.gravity_mode = "point" if name == "gravity_center" else "direction"
                setattr(fresh.params, name, value)
                fresh.step(6)
                state = fresh.read_state()
                if not _finite(state):
                    bad.append((wind, name, value))
                setattr(fresh.params, name, getattr(defaults, name))
                fresh.reset()
    assert not bad
    assert fresh.nonfinite_resets == resets


def test_extreme_blades_stay_finite():
    """Blades at the largest root coordinate, height, width and stiffness accepted."""
    n = 64
    rng = np.random.default_rng(4)
    v0 = np.zeros((n, 3))
    v0[:, 0] = MAX_COORDINATE - rng.uniform(0, 10, n)
    blades = gw.Blades(v0=v0, up=np.tile([1e-300, 1.0, 0.0], (n, 1)), orientation=rng.uniform(-1e6, 1e6, n),
                       height=np.where(np.arange(n) % 2, MAX_BLADE_HEIGHT, 1e-3),
                       width=np.full(n, MAX_BLADE_WIDTH),
                       stiffness=np.where(np.arange(n) % 3, MAX_BLADE_STIFFNESS, 1e-6))
    field = gw.GrassField(blades, params=gw.GrassParams(stiffness_scale=20.0, dt=0.05, wind_strength=200.0,
                                                        gravity=50.0))
    try:
        field.step(STEPS)
        state = field.read_state()
        assert _finite(state)
        assert field.nonfinite_resets == 0
    finally:
        field.release()


@pytest.mark.parametrize("body", ["return vec3<f32>(bitcast<f32>(0x7fc00000u), 0.0, 0.0);",  # NaN
                                  "return vec3<f32>(0.0, 0.0, exp(100.0 + t));"])  # overflow: inf
def test_a_wind_wgsl_that_returns_nan_or_inf_leaves_the_blades_at_rest_with_one_warning(body, fresh, blades):
    fresh.params.wind_field = "custom"
    fresh.params.wind_wgsl = body
    resets = fresh.nonfinite_resets
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(10):
            fresh.step(1)
        state = fresh.read_state()
        fresh.step(5)
        state2 = fresh.read_state()  # the flag is set again: the same cause, no second warning
    mine = [w for w in caught if issubclass(w.category, NonFiniteStateWarning)]
    assert len(mine) == 1, [str(w.message) for w in mine]
    assert "wind WGSL" in str(mine[0].message) and "at rest" in str(mine[0].message)
    assert mine[0].filename == __file__  # attributed to the caller's read_state() line, not to grasswidget's
    assert fresh.nonfinite_resets - resets == 2  # both readbacks found the flag, set again after clearing
    for s in (state, state2):
        assert _finite(s) and _at_rest(s, blades)
        assert np.all(s["collision"] == 0.0)
    # A normal wind restored: the blades move again from rest, finite, with no reset.
    fresh.params.wind_wgsl = "return vec3<f32>(20.0, 0.0, 0.0);"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fresh.step(20)
        state = fresh.read_state()
    assert not [w for w in caught if issubclass(w.category, NonFiniteStateWarning)]
    assert _finite(state) and not _at_rest(state, blades)
    assert np.all(state["v2"][:, 0] > blades.v0[:, 0])  # blown towards +x


def test_only_the_blades_that_went_non_finite_are_reset(fresh, blades):
    """NaN wind on the blades with x > 0 only: those at rest, the others blown as the reference says."""
    fresh.params.wind_field = "custom"
    fresh.params.wind_wgsl = "if (p.x > 0.0) { return vec3<f32>(sqrt(-1.0 - abs(t)), 0.0, 0.0); }\nreturn vec3<f32>(0.0, 0.0, 15.0);"
    with pytest.warns(NonFiniteStateWarning, match="wind WGSL"):
        fresh.step(12)
        state = fresh.read_state()

    def wind(p, t):
        w = np.zeros_like(p)
        w[:, 2] = 15.0
        w[p[:, 0] > 0, 0] = np.nan
        return w

    with np.errstate(invalid="ignore"):
        cpu = ref.simulate(blades.rest_state(), fresh.params, 12, user_wind=wind)
    assert _finite(state)
    assert np.isfinite(cpu["v2"]).all()
    right = blades.v0[:, 0] > 0
    assert right.any() and (~right).any()
    assert np.abs(state["v2"] - cpu["v2"]).max() < 1e-4 * float(blades.height.max())
    rest = blades.v0 + blades.up * blades.height[:, None]
    assert np.abs(state["v2"][right] - rest[right]).max() < 1e-5
    assert np.linalg.norm(state["v2"][~right] - rest[~right], axis=1).min() > 1e-3


def test_a_users_blade_math_function_returning_nan_is_named_as_the_cause():
    from grasswidget.core.wgsl_overrides import FunctionOverrides

    blades = gw.Blades.on_plane(128, size=4.0, seed=6)
    field = gw.GrassField(blades)
    nan_force = """fn wind_force(W: vec3<f32>, v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    return vec3<f32>(sqrt(-1.0 - height));
}
"""
    try:
        field.set_function_overrides(FunctionOverrides(nan_force, ("wind_force",), "the forces exercise"))
        field.step(8)
        with pytest.warns(NonFiniteStateWarning, match="blade-math functions"):
            state = field.read_state()
        assert _finite(state) and _at_rest(state, blades)
    finally:
        field.release()


def test_a_non_finite_state_is_refused_by_write_state_and_nothing_changes(fresh, blades):
    fresh.step(5)
    before = fresh.read_state()
    for key, row in (("v2", 7), ("collision", 3)):
        state = {k: np.array(v) for k, v in before.items()}
        state[key][row] = np.nan
        with pytest.raises(gw.GrassValueError, match=rf"state\['{key}'\] must be finite; [13] of"):
            fresh.write_state(state)
    after = fresh.read_state()
    assert all(np.array_equal(after[k], before[k]) for k in ("v1", "v2", "collision"))
    assert not fresh.check_finite()


def test_the_frame_stats_bring_the_flag_without_a_readback_of_their_own():
    scene = gw.GrassScene(gw.Blades.on_plane(256, size=4.0, seed=2), size=(64, 48),
                          params=gw.GrassParams(wind_field="custom", wind_wgsl="return vec3<f32>(sqrt(-1.0 - abs(t)));"))
    try:
        with pytest.warns(NonFiniteStateWarning, match="wind WGSL"):
            for _ in range(6):  # the stats' readbacks land a frame or two later
                scene.step(2)
                scene.render()
                scene.field.stats.poll()
                if scene.field.nonfinite_resets:
                    break
        assert scene.field.nonfinite_resets >= 1
        assert _finite(scene.field.read_state())
    finally:
        scene.release()


# ------------------------------------------------------------------ step(n): the limit, the interrupt


def test_step_refuses_more_than_max_steps_in_every_kernel_entry(field, widget):
    counted = (field.step_count, widget.view.scene.field.step_count, widget.sim_time)
    for step in (field.step, widget.step):
        for n in (MAX_STEPS + 1, 2**40, -1, 2.5, True):
            with pytest.raises(gw.GrassValueError, match=r"\[0, 1,000,000\].*MAX_STEPS"):
                step(n)
    assert (field.step_count, widget.view.scene.field.step_count, widget.sim_time) == counted  # nothing ran


def test_grass_scene_step_refuses_2_to_the_40():
    scene = gw.GrassScene(gw.Blades.on_plane(64, seed=1), size=(32, 24))
    try:
        with pytest.raises(ValueError, match="MAX_STEPS"):
            scene.step(2**40)
        assert scene.field.step_count == 0
    finally:
        scene.release()


def test_ctrl_c_between_submissions_stops_with_the_steps_counted(fresh, blades, monkeypatch, ctrl_c_enabled):
    """A run of 40 dispatches of 4 steps; SIGINT during the 3rd: the 3rd completes, then
    StepsInterrupted; step_count and the state are those of 12 steps."""
    monkeypatch.setattr(engine_inputs, "BLADE_STEPS_PER_DISPATCH", 4 * fresh.count)
    calls = []
    write = fresh.simulation.write_uniform

    def write_and_interrupt(steps, time0):
        calls.append(steps)
        if len(calls) == 3:
            os.kill(os.getpid(), signal.SIGINT)
        return write(steps, time0)

    monkeypatch.setattr(fresh.simulation, "write_uniform", write_and_interrupt)
    fresh.params.wind_strength = 30.0
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(StepsInterrupted) as info:
        fresh.step(160)
    assert isinstance(info.value, KeyboardInterrupt)
    assert (info.value.done, info.value.requested) == (12, 160)
    assert fresh.step_count == 12
    assert signal.getsignal(signal.SIGINT) is before
    state = fresh.read_state()
    cpu = ref.simulate(blades.rest_state(), fresh.params, 12)
    assert np.abs(state["v2"] - cpu["v2"]).max() < 1e-4 * float(blades.height.max())


def test_widget_step_interrupted_counts_the_steps_done(widget, monkeypatch, ctrl_c_enabled):
    field = widget.view.scene.field
    monkeypatch.setattr(engine_inputs, "BLADE_STEPS_PER_DISPATCH", 8 * field.count)
    calls = []
    write = field.simulation.write_uniform

    def write_and_interrupt(steps, time0):
        calls.append(steps)
        if len(calls) == 2:
            os.kill(os.getpid(), signal.SIGINT)
        return write(steps, time0)

    monkeypatch.setattr(field.simulation, "write_uniform", write_and_interrupt)
    t0 = widget.sim_time
    with pytest.raises(StepsInterrupted) as info:
        widget.step(800)
    assert info.value.done == 16 == field.step_count
    assert widget.sim_time - t0 == pytest.approx(16 * widget.params.dt)
    widget.step(3)  # still usable
    assert field.step_count == 19
