"""The WGSL simulation against the NumPy reference, and invariants on the GPU."""

import numpy as np
import pytest

from grasswidget.core import reference as ref


# Fixture scene (conftest) of the session's small_blades.
SCENE = dict(size=(96, 72))


def _rel_err(gpu, cpu, b):
    return max(
        (np.linalg.norm(gpu[k] - cpu[k], axis=1) / b.height).max() for k in ("v1", "v2")
    )


@pytest.mark.parametrize("steps", [1, 200])
@pytest.mark.parametrize("params", [dict(), dict(wind_strength=40, wind_direction=35, gravity=12)])
def test_gpu_matches_reference(scene, small_blades, steps, params):
    for name, value in params.items():
        setattr(scene.params, name, value)
    try:
        scene.field.reset()
        scene.step(steps)
        gpu = scene.field.read_state()
        cpu = ref.simulate(small_blades.rest_state(), scene.params, steps)
        err = _rel_err(gpu, cpu, small_blades)
        print(f"steps={steps} params={params} max |gpu - ref| / h = {err:.2e}")
        assert err < 1e-4
        # and the blades really moved (the comparison is not of two rest poses)
        assert np.abs(cpu["v2"] - small_blades.rest_state()["v2"]).max() > 1e-3
    finally:
        scene.params.wind_strength, scene.params.wind_direction, scene.params.gravity = 5.0, 0.0, 9.8


def test_steps_add_up(scene, small_blades):
    """step(150) twice equals step(300): time continues across calls."""
    scene.field.reset()
    scene.step(150)
    scene.step(150)
    a = scene.field.read_state()
    cpu = ref.simulate(small_blades.rest_state(), scene.params, 300)
    assert _rel_err(a, cpu, small_blades) < 1e-4
    assert scene.field.step_count == 300


@pytest.mark.parametrize(
    "params",
    [dict(), dict(wind_strength=150), dict(gravity=50, wind_strength=200, stiffness_scale=0.01, dt=0.05)],
)
def test_gpu_invariants_after_1000_steps(scene, small_blades, params):
    old = {k: getattr(scene.params, k) for k in params}
    scene.params.set_trait  # noqa: B018
    for k, v in params.items():
        setattr(scene.params, k, v)
    try:
        scene.field.reset()
        scene.step(1000)
        s = scene.field.read_state()
    finally:
        for k, v in old.items():
            setattr(scene.params, k, v)
    h = small_blades.height
    assert all(np.all(np.isfinite(s[k])) for k in ("v0", "v1", "v2"))
    assert np.all(np.sum((s["v2"] - s["v0"]) * s["up"], axis=1) >= -1e-5 * h)
    length = ref.curve_length(s["v0"].astype(np.float64), s["v1"].astype(np.float64), s["v2"].astype(np.float64))
    assert np.all(np.abs(length - h) <= 0.01 * h)


def test_gpu_stiffer_blades_lean_less_and_recover(scene, small_blades):
    def lean(s):
        d = s["v2"] - s["v0"]
        return np.linalg.norm(d - s["up"] * np.sum(d * s["up"], axis=1)[:, None], axis=1)

    p = scene.params
    p.wind_strength = 25
    try:
        means = []
        for k in (0.5, 4.0):
            p.stiffness_scale = k
            scene.field.reset()
            scene.step(400)
            means.append(lean(scene.field.read_state()).mean())
        assert means[1] < 0.6 * means[0]
        # wind stops: back to the calm equilibrium
        p.stiffness_scale = 1.0
        scene.field.reset()
        p.wind_strength = 0
        scene.step(1500)
        calm = scene.field.read_state()["v2"]
        scene.field.reset()
        p.wind_strength = 60
        scene.step(500)
        windy = scene.field.read_state()["v2"]
        p.wind_strength = 0
        scene.step(1500)
        back = scene.field.read_state()["v2"]
        assert np.abs(windy - calm).max() > 0.3
        assert np.abs(back - calm).max() < 1e-3
    finally:
        p.wind_strength, p.stiffness_scale = 5.0, 1.0


def test_step_rejects_bad_n(scene):
    for bad in (-1, 1.5, "3", True):
        with pytest.raises(ValueError, match="n"):
            scene.step(bad)
    scene.step(0)  # allowed, does nothing
