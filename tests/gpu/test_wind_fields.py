"""Wind fields (wave, radial, vortex, noise, custom WGSL) and gravity direction:
GPU against the NumPy reference, what each field does, extremes, bad snippets."""

import numpy as np
import pytest
from traitlets import TraitError

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.core.params import WIND_FIELDS
from grasswidget.core.shader_files import render_wgsl

from conftest import HARNESS_BINDINGS

# Fixtures blades, field and fresh (conftest): one field for the module, default params.
BLADES = dict(count=2048, size=12.0, seed=7)


def _set(params, values):
    for name, value in values.items():
        setattr(params, name, value)


def _rel_err(gpu, cpu, b):
    return max((np.linalg.norm(gpu[k] - cpu[k], axis=1) / b.height).max() for k in ("v1", "v2"))


# Custom wind: a WGSL snippet and its NumPy twin.
GOOD_WGSL = """let gust = 0.5 + 0.5 * sin(2.0 * t + 0.3 * p.x);
return vec3<f32>(12.0 * gust, 0.0, 4.0 * cos(0.2 * p.z));"""


def good_wind(p, t):
    gust = 0.5 + 0.5 * np.sin(2.0 * t + 0.3 * p[:, 0])
    return np.stack([12.0 * gust, np.zeros(len(p)), 4.0 * np.cos(0.2 * p[:, 2])], axis=1)


FIELDS = {
    "wave": dict(wind_field="wave", wind_strength=30.0, wind_direction=35.0),
    "radial": dict(wind_field="radial", wind_strength=40.0, wind_center=(1.0, 0.5, -2.0), wind_radius=4.0),
    "vortex": dict(wind_field="vortex", wind_strength=40.0, wind_center=(-1.0, 0.0, 1.5), wind_radius=3.0),
    "noise": dict(wind_field="noise", wind_strength=35.0, wind_wavelength=5.0, wind_direction=-60.0),
    "gravity-direction": dict(wind_field="wave", gravity_direction=(0.6, -1.0, 0.3), gravity=12.0),
}


def test_every_wind_field_has_a_gpu_vs_reference_case():
    """A new member of enums.WindField gets a FIELDS entry (custom has its own test below)."""
    from grasswidget.core.enums import WindField

    missing = set(WindField.labels()) - {"custom"} - {values["wind_field"] for values in FIELDS.values()}
    assert not missing, f"add a FIELDS entry (params for a GPU vs reference run) for {sorted(missing)}"


@pytest.mark.parametrize("steps", [1, 200])
@pytest.mark.parametrize("name", list(FIELDS))
def test_gpu_matches_reference(fresh, blades, name, steps):
    _set(fresh.params, FIELDS[name])
    fresh.step(steps)
    gpu = fresh.read_state()
    cpu = ref.simulate(blades.rest_state(), fresh.params, steps)
    err = _rel_err(gpu, cpu, blades)
    print(f"{name:18s} {steps:4d} steps: max |gpu - ref| / h = {err:.2e}")
    assert err < 1e-4
    assert np.abs(cpu["v2"] - blades.rest_state()["v2"]).max() > 1e-3  # really moved


def test_custom_wind_matches_numpy_twin(fresh, blades):
    fresh.set_wind_wgsl(GOOD_WGSL)  # compiles and selects wind_field "custom"
    assert fresh.params.wind_field == "custom" and fresh.params.wind_wgsl == GOOD_WGSL
    for steps in (1, 199):
        fresh.step(steps)
    gpu = fresh.read_state()
    cpu = ref.simulate(blades.rest_state(), fresh.params, 200, user_wind=good_wind)
    err = _rel_err(gpu, cpu, blades)
    print(f"custom wind 200 steps: max |gpu - ref| / h = {err:.2e}")
    assert err < 1e-4
    calm = ref.simulate(blades.rest_state(), gw.GrassParams(wind_strength=0), 200)
    assert np.abs(cpu["v2"] - calm["v2"]).max() > 0.1  # the custom wind does blow


@pytest.mark.parametrize(
    "snippet, line",
    [
        ("let gust = 0.5 + 0.5 * sin(2.0 * t);\nlet w = vec3<f32>(gust, 0.0, 0.0);\nreturn w * undefined_name;", 3),
        ("let a = 1;\nreturn vec3<f32>(a, 0.0, 0.0);", 2),  # type error (validation, not parsing)
        ("let a = 2.0\nreturn vec3<f32>(a);", 2),  # missing semicolon
        ("\n\n\n\nreturn 1.0;", 5),
    ],
)
def test_bad_wgsl_raises_with_line_and_keeps_old_wind(fresh, blades, snippet, line):
    fresh.set_wind_wgsl(GOOD_WGSL)
    with pytest.raises(gw.WindShaderError, match=f"wind_wgsl line {line}") as info:
        fresh.set_wind_wgsl(snippet)
    assert info.value.line == line
    with pytest.raises(gw.WindShaderError) as info2:  # the trait route too
        fresh.params.wind_wgsl = snippet
    assert info2.value.line == line
    assert fresh.params.wind_wgsl == GOOD_WGSL  # the old snippet stays in force
    fresh.reset()
    fresh.step(200)
    gpu = fresh.read_state()
    cpu = ref.simulate(blades.rest_state(), fresh.params, 200, user_wind=good_wind)
    assert _rel_err(gpu, cpu, blades) < 1e-4


def test_bad_wgsl_at_construction(blades):
    with pytest.raises(gw.WindShaderError, match="line 1"):
        gw.GrassField(blades, params=gw.GrassParams(wind_wgsl="return nope;"))
    with pytest.raises(TypeError, match="wind_wgsl"):
        gw.GrassField.set_wind_wgsl(None, 42)


def test_custom_wind_without_twin_is_an_error_in_the_reference(blades):
    p = gw.GrassParams(wind_field="custom", wind_wgsl=GOOD_WGSL)
    with pytest.raises(ValueError, match="user_wind"):
        ref.simulate(blades.rest_state(), p, 1)
    # an empty snippet means no wind on both sides
    p = gw.GrassParams(wind_field="custom")
    calm = ref.simulate(blades.rest_state(), gw.GrassParams(wind_strength=0), 5)
    assert np.allclose(ref.simulate(blades.rest_state(), p, 5)["v2"], calm["v2"])


def test_bad_wind_params():
    p = gw.GrassParams()
    with pytest.raises(TraitError, match="wind_field"):
        p.wind_field = "tornado"
    with pytest.raises(TraitError, match="wind_center"):
        p.wind_center = (0, np.nan, 0)
    with pytest.raises(TraitError, match="wind_radius"):
        p.wind_radius = 0
    with pytest.raises(TraitError, match="gravity_direction"):
        p.gravity_direction = (0, 0, 0)
    with pytest.raises(TraitError, match="gravity_mode"):
        p.gravity_mode = "sideways"


# ----------------------------------------------------------------- what the fields do


def _wind_push(field, values, steps=240):
    """Tip displacement caused by the wind: v2(wind) - v2(same run without wind)."""
    _set(field.params, {**values, "wind_strength": 0.0})
    field.reset()
    field.step(steps)
    calm = field.read_state()
    _set(field.params, values)
    field.reset()
    field.step(steps)
    windy = field.read_state()
    return windy, windy["v2"] - calm["v2"]


def test_radial_pushes_outward(fresh):
    center = np.array([0.5, 0.0, -0.5])
    state, push = _wind_push(fresh, dict(wind_field="radial", wind_strength=40.0, wind_center=tuple(center), wind_radius=3.0))
    r = (state["v0"] - center)[:, [0, 2]]
    dist = np.linalg.norm(r, axis=1)
    away = r / np.maximum(dist, 1e-9)[:, None]
    outward = np.sum(push[:, [0, 2]] * away, axis=1)
    ring = (dist > 0.5) & (dist < 5.0)
    assert np.mean(outward[ring] > 0) > 0.97
    assert np.median(outward[ring]) > 0.2


def test_vortex_turns_tips_tangentially(fresh):
    center = np.array([-0.5, 0.0, 0.5])
    state, push = _wind_push(fresh, dict(wind_field="vortex", wind_strength=40.0, wind_center=tuple(center), wind_radius=3.0))
    r = (state["v0"] - center)[:, [0, 2]]
    dist = np.linalg.norm(r, axis=1)
    away = r / np.maximum(dist, 1e-9)[:, None]
    tangent = np.stack([-away[:, 1], away[:, 0]], axis=1)  # from +x towards +z
    along = np.sum(push[:, [0, 2]] * tangent, axis=1)
    radial = np.sum(push[:, [0, 2]] * away, axis=1)
    ring = (dist > 0.5) & (dist < 5.0)
    assert np.mean(along[ring] > 0) > 0.97
    assert np.median(along[ring]) > 3 * np.median(np.abs(radial[ring]))


def test_noise_gusts_vary_in_space(fresh):
    _, push = _wind_push(fresh, dict(wind_field="noise", wind_strength=40.0, wind_wavelength=4.0, wind_direction=0.0))
    angle = np.degrees(np.arctan2(push[:, 2], push[:, 0]))
    strength = np.linalg.norm(push, axis=1)
    assert np.mean(np.abs(angle) < 90) > 0.8  # mostly downwind (+x) ...
    assert np.std(angle) > 15 and np.std(strength) > 0.1 * np.mean(strength)  # ... but gusty


@pytest.mark.parametrize("name", WIND_FIELDS)
def test_no_nan_at_extremes(fresh, blades, name):
    values = dict(wind_field=name, wind_strength=200.0, dt=0.05, gravity=50.0, stiffness_scale=0.01,
                  wind_center=tuple(float(x) for x in blades.v0[0]), wind_radius=0.01, wind_wavelength=0.1,
                  wind_speed=50.0)
    if name == "custom":
        fresh.set_wind_wgsl("return vec3<f32>(1e4 * sin(50.0 * t), -1e4, 1e4 * cos(p.x));")
    _set(fresh.params, values)
    fresh.step(400)
    s = fresh.read_state()
    h = blades.height
    assert all(np.all(np.isfinite(s[k])) for k in ("v1", "v2", "collision"))
    assert np.all(np.sum((s["v2"] - s["v0"]) * s["up"], axis=1) >= -1e-5 * h)
    length = ref.curve_length(*(s[k].astype(np.float64) for k in ("v0", "v1", "v2")))
    assert np.all(np.abs(length - h) <= 0.01 * h)


# ----------------------------------------------------------------- simplex noise, WGSL vs NumPy


def _run_wgsl(run_compute, body_fn, inputs, out_format):
    """Evaluate a blade_math.wgsl expression of ``q`` (a vec2<f32>) on the GPU for each input."""
    code = render_wgsl("blade_math.wgsl") + HARNESS_BINDINGS + f"""
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x;
    if (i >= arrayLength(&harness_in) / 2u) {{ return; }}
    let q = vec2<f32>(bitcast<f32>(harness_in[2u * i]), bitcast<f32>(harness_in[2u * i + 1u]));
    harness_out[i] = bitcast<u32>({body_fn});
}}
"""
    words = np.ascontiguousarray(inputs, np.float32).view(np.uint32)
    out = run_compute(code, words, 1, len(words))[:, 0]
    return out.view(np.float32) if out_format == "f32" else out


def test_simplex_noise_wgsl_equals_numpy(run_compute):
    rng = np.random.default_rng(1)
    pts = np.concatenate([rng.uniform(-60, 60, (20000, 2)), rng.uniform(-2, 2, (5000, 2))]).astype(np.float32)
    gpu = _run_wgsl(run_compute, "simplex_noise2(q.x, q.y)", pts, "f32")
    cpu = ref.simplex_noise2(pts[:, 0].astype(np.float64), pts[:, 1].astype(np.float64))
    err = np.abs(gpu - cpu)
    near = np.abs(pts).max(axis=1) <= 2
    print(f"simplex noise: max |wgsl - numpy| = {err[near].max():.2e} for |q| <= 2, "
          f"{err.max():.2e} for |q| <= 60; range [{cpu.min():.3f}, {cpu.max():.3f}]")
    # float32 precision: the error grows with |q| (x0 = x - (i - t) cancels digits)
    assert err[near].max() < 2e-6
    assert err.max() < 1e-4
    assert cpu.min() < -0.8 and cpu.max() > 0.8 and np.abs(cpu).max() <= 1.05


def test_noise_hash_wgsl_equals_numpy(run_compute):
    ij = np.array([[0, 0], [1, 0], [0, 1], [-1, -1], [12345, -678], [-2**24, 2**24 - 1], [77, 77]], np.int64)
    rng = np.random.default_rng(2)
    ij = np.concatenate([ij, rng.integers(-10**6, 10**6, (500, 2))])
    gpu = _run_wgsl(run_compute, "noise_hash(i32(q.x), i32(q.y))", ij.astype(np.float32), "u32")
    assert np.array_equal(gpu, ref.noise_hash(ij[:, 0], ij[:, 1]).astype(np.uint32))  # exact (|i| <= 2^24)
