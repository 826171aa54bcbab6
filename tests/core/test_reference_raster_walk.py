"""The reference walk of the compute rasterizer (reference.raster_walk) steps by raster_step:
every v it writes a pixel at is one of the samples v_0 = 0, v_(k+1) = min(v_k + raster_step(v_k), 1)
taken in float32, and the samples it skips are those whose cross-section writes nothing."""

import numpy as np

from grasswidget import reference as ref
from grasswidget.core.enums import BladeShape


def _samples(c0, c1, c2, size):
    """The walk's v samples built from raster_step itself (float32, as raster.wgsl)."""
    f32 = np.float32
    s0, s1, s2 = (ref.clip_to_pixel(np.asarray(c, f32), size)[:2] for c in (c0, c1, c2))
    v, vs = f32(0.0), []
    for _ in range(int(ref.RASTER_MAX_SAMPLES) + 1):
        vs.append(v)
        if v >= 1.0:
            break
        v = f32(min(f32(v + f32(ref.raster_step(s0, s1, s2, v))), f32(1.0)))
    return np.array(vs, f32)


def test_the_walk_writes_at_the_samples_of_raster_step():
    rng = np.random.default_rng(7)
    size = (160, 120)
    checked = 0
    for blade in range(60):
        w = rng.uniform(0.8, 4.0, 3)
        c0, c1, c2 = (np.array([*rng.normal(0, 0.6, 2) * wk, 0.5 * wk, wk]) for wk in w)
        across = np.array([*rng.normal(0, 0.03, 2), 0.0, 0.0])
        xs, ys, ds, vs = ref.raster_walk(c0, c1, c2, across, blade, int(BladeShape.QUAD), 0.5, size)
        samples = _samples(c0, c1, c2, size).astype(np.float64)
        assert np.isin(vs, samples).all(), blade
        checked += len(np.unique(vs))
    assert checked > 500  # many distinct samples written, not a handful
