"""The pure core: blade generation and parameter validation (no GPU)."""

import math
import subprocess
import sys

import numpy as np
import pytest
from traitlets import TraitError

import grasswidget as gw
from grasswidget.core.params import GrassParams, RangedFloat, RangedInt


def test_core_imports_no_gpu_code():
    code = (
        "import sys, grasswidget, grasswidget.core.reference, grasswidget.core.blades, grasswidget.core.params;"
        "bad=[m for m in ('wgpu','pygfx','rendercanvas') if m in sys.modules]; print(bad); assert not bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_on_plane_layout_and_ranges():
    b = gw.Blades.on_plane(5000, size=15.0, seed=7)
    assert len(b) == 5000
    assert np.all(np.abs(b.v0[:, [0, 2]]) <= 7.5) and np.all(b.v0[:, 1] == 0)
    assert np.allclose(b.up, [0, 1, 0])
    assert b.height.min() >= 1.3 and b.height.max() <= 2.5
    assert b.width.min() >= 0.1 and b.width.max() <= 0.14
    assert b.stiffness.min() >= 7 and b.stiffness.max() <= 13
    assert b.orientation.min() >= 0 and b.orientation.max() < 2 * math.pi
    p = b.packed()
    assert p.shape == (5000, 4, 4) and p.dtype == np.float32
    assert np.allclose(p[:, 0, :3], b.v0) and np.allclose(p[:, 0, 3], b.orientation)
    assert np.allclose(p[:, 1, 3], b.height) and np.allclose(p[:, 2, 3], b.width)
    assert np.allclose(p[:, 3, 3], b.stiffness)
    # rest pose: v1 = v2 = v0 + h up
    assert np.allclose(p[:, 2, :3], b.v0 + b.up * b.height[:, None])


def test_on_plane_uniform_and_in_patches():
    b = gw.Blades.on_plane(40000, size=10.0, seed=1)
    # uniform: every 1 m^2 cell gets ~400 blades
    hist, _, _ = np.histogram2d(b.v0[:, 0], b.v0[:, 2], bins=10, range=[[-5, 5], [-5, 5]])
    assert hist.min() > 300 and hist.max() < 500
    # ids in patches: 32 consecutive ids (GPU threads that run together) lie within
    # about two 4 x 4-cell tiles (cells of 5 cm here), not across the field
    extents = [np.ptp(b.v0[i:i + 32][:, [0, 2]], axis=0).max() for i in range(0, len(b) - 32, 32)]
    assert np.median(extents) < 0.5 and np.percentile(extents, 95) < 2.0
    # each patch in random order: ids modulo distance culling's buckets are spread
    # evenly over the ground (every 1 m^2 cell holds each residue about equally)
    ids = np.arange(len(b))
    for buckets in (4, 8, 10, 16):
        for r in range(buckets):
            hist_r, _, _ = np.histogram2d(b.v0[ids % buckets == r, 0], b.v0[ids % buckets == r, 2], bins=10,
                                          range=[[-5, 5], [-5, 5]])
            assert np.all(np.abs(hist_r / hist * buckets - 1.0) < 0.5), (buckets, r)
    # and within a patch no residue takes one fixed place: residue 0's position inside
    # its tile is spread (not one corner of every tile)
    tile = 10.0 / np.ceil(np.sqrt(len(b))) * 4
    inside = np.mod(b.v0[ids % 4 == 0][:, [0, 2]] + 5.0, tile) / tile
    assert np.all(np.histogram(inside[:, 0], bins=4, range=(0, 1))[0] > 0.15 * len(inside))


def test_same_seed_same_blades():
    a, b, c = (gw.Blades.on_plane(300, seed=s) for s in (4, 4, 5))
    assert np.array_equal(a.packed(), b.packed())
    assert not np.array_equal(a.packed(), c.packed())


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(count=0), "count"),
        (dict(count=-3), "count"),
        (dict(count=2.5), "count"),
        (dict(count=10, size=0), "size"),
        (dict(count=10, size=float("nan")), "size"),
        (dict(count=10, height=(2, 1)), "height"),
        (dict(count=10, width=(0, 0.1)), "width"),
        (dict(count=10, stiffness=(float("nan"), 3)), "stiffness"),
    ],
)
def test_on_plane_bad_input(kwargs, word):
    with pytest.raises(ValueError, match=word):
        gw.Blades.on_plane(**kwargs)


def _numeric_traits():
    p = GrassParams()
    return [(name, p.traits()[name]) for name in p.trait_names() if isinstance(p.traits()[name], (RangedFloat, RangedInt))]


def test_defaults():
    p = GrassParams()
    assert p.gravity == 9.8 and p.front_gravity == 0.25 and p.stiffness_scale == 1.0
    assert 3 <= p.wind_strength <= 8 and p.wind_field == "wave"
    assert p.dt == pytest.approx(1 / 120)
    t = p.traits()
    assert (t["gravity"].lo, t["gravity"].hi) == (0, 50)
    assert (t["stiffness_scale"].lo, t["stiffness_scale"].hi) == (0.01, 20)
    assert (t["wind_strength"].lo, t["wind_strength"].hi) == (0, 200)


@pytest.mark.parametrize("name, trait", _numeric_traits(), ids=lambda x: x if isinstance(x, str) else "")
def test_every_numeric_param_refuses_bad_values(name, trait):
    p = GrassParams()
    before = getattr(p, name)
    bad = [trait.hi + max(1, abs(trait.hi)), trait.lo - max(1, abs(trait.lo))]
    if isinstance(trait, RangedFloat):
        bad += [float("nan"), float("inf"), -float("inf")]
    for value in bad:
        with pytest.raises(TraitError) as info:
            setattr(p, name, value)
        msg = str(info.value)
        assert name in msg and f"{trait.lo:g}" in msg and f"{trait.hi:g}" in msg
        assert getattr(p, name) == before  # state kept


def test_bad_wind_field_and_type():
    p = GrassParams()
    with pytest.raises(TraitError, match="wind_field"):
        p.wind_field = "tornado"
    with pytest.raises(TraitError, match="gravity"):
        p.gravity = "strong"
    assert p.wind_field == "wave" and p.gravity == 9.8
    with pytest.raises(TraitError, match="gravity"):
        GrassParams(gravity=-1)


def test_every_on_off_param_refuses_what_is_not_a_bool_as_a_parameter_error():
    """Each True/False trait (and each "auto" switch) takes bools, NumPy's booleans and 0/1, and
    refuses anything else with a ParameterError (a ValueError, a GrassError) naming it; the value
    stays."""
    from traitlets import Bool

    from grasswidget.core.auto_switches import AutoSwitch

    p = GrassParams()
    names = [n for n, t in p.traits().items() if isinstance(t, (Bool, AutoSwitch)) and not n.startswith("_")]
    assert {"lod", "cull_frustum", "shadows", "cull_occlusion", "compute_raster"} <= set(names)
    for name in names:
        before = getattr(p, name)
        for bad in ("yes", None, 2, 0.5, [True]):
            with pytest.raises(gw.ParameterError, match=name) as info:
                setattr(p, name, bad)
            assert isinstance(info.value, ValueError)
            assert getattr(p, name) == before
        for good, want in ((np.bool_(not before), not before), (np.int64(1), True), (0, False)):
            setattr(p, name, good)
            assert getattr(p, name) is want
        setattr(p, name, before)


def test_preset_params_are_one_table_for_scene_and_widget():
    """GrassScene.preset and GrassWidget(preset=...) take a preset's own parameter values from
    core.presets.preset_params: the cis565 preset culls by distance to zero at 40 m in both."""
    import pytest

    from grasswidget.core.presets import PRESETS, preset_params
    from grasswidget.errors import GrassValueError

    assert preset_params("cis565") == {"cull_distance_max": 40.0}
    assert preset_params("meadow") == {}
    assert set(PRESETS) == {"cis565", "meadow"}
    p = preset_params("cis565")
    p["cull_distance_max"] = 1.0                      # a copy: the table stays as it is
    assert preset_params("cis565")["cull_distance_max"] == 40.0
    with pytest.raises(GrassValueError, match="preset must be one of cis565, meadow"):
        preset_params("lawn")
