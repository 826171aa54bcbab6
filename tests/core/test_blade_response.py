"""Tip offset and bend from a blade state (grasswidget.core.blade_response) against a
per-blade computation written independently (Python floats and math, one blade at a time)."""

import math

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core.blade_response import bend_angles_deg, response_summary, tip_offsets


def _one_blade(v0, v2, up, h):
    rest = [v0[i] + up[i] * h for i in range(3)]
    offset = math.sqrt(sum((v2[i] - rest[i]) ** 2 for i in range(3)))
    d = [v2[i] - v0[i] for i in range(3)]
    dn, un = math.sqrt(sum(x * x for x in d)), math.sqrt(sum(x * x for x in up))
    cos = sum(d[i] * up[i] for i in range(3)) / (dn * un)
    return offset, math.degrees(math.acos(max(-1.0, min(1.0, cos))))


def _bent_state(n=300, seed=3):
    rng = np.random.default_rng(seed)
    b = gw.Blades.on_plane(n, seed=seed)
    up = rng.normal(size=(n, 3))
    up[:, 1] = np.abs(up[:, 1]) + 1.0
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    v2 = b.v0 + up * b.height[:, None] + rng.normal(scale=0.4, size=(n, 3))
    return {"v0": b.v0, "v1": b.v0, "v2": v2, "up": up, "height": b.height}


def test_tip_offset_and_bend_match_a_per_blade_computation():
    s = _bent_state()
    want = np.array([_one_blade(s["v0"][k], s["v2"][k], s["up"][k], float(s["height"][k]))
                     for k in range(len(s["height"]))])
    assert np.allclose(tip_offsets(s), want[:, 0], rtol=1e-9, atol=1e-9)
    assert np.allclose(bend_angles_deg(s), want[:, 1], rtol=1e-9, atol=1e-7)
    summary = response_summary(s)
    assert summary["blades"] == 300
    assert summary["mean_tip_offset"] == pytest.approx(want[:, 0].mean(), rel=1e-9)
    assert summary["mean_bend_deg"] == pytest.approx(want[:, 1].mean(), rel=1e-9)


def test_rest_pose_is_zero_and_a_flat_blade_is_ninety_degrees():
    b = gw.Blades.on_plane(50, seed=1)
    rest = {"v0": b.v0, "v2": b.v0 + b.up * b.height[:, None], "up": b.up, "height": b.height}
    assert np.allclose(tip_offsets(rest), 0.0, atol=1e-6)
    assert np.allclose(bend_angles_deg(rest), 0.0, atol=1e-3)
    flat = dict(rest, v2=b.v0 + np.array([1.0, 0.0, 0.0]) * b.height[:, None])
    assert np.allclose(bend_angles_deg(flat), 90.0)
    assert np.allclose(tip_offsets(flat), b.height * math.sqrt(2.0), rtol=1e-6)


def test_bad_state_names_what_is_missing_or_misshapen():
    with pytest.raises(gw.GrassValueError, match="missing up"):
        tip_offsets({"v0": np.zeros((2, 3)), "v2": np.zeros((2, 3)), "height": np.ones(2)})
    with pytest.raises(gw.GrassValueError, match=r"state\['v2'\] must have shape \(2, 3\)"):
        bend_angles_deg({"v0": np.zeros((2, 3)), "v2": np.zeros((3, 3)), "up": np.zeros((2, 3)), "height": np.ones(2)})
    with pytest.raises(gw.GrassTypeError):
        response_summary([1, 2])
