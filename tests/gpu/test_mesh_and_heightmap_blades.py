"""Grass on any mesh (Blades.on_mesh), on a height map (Blades.on_heightmap), and
on a small planet with gravity toward its centre."""

import subprocess
import sys
import types

import numpy as np
import pygfx as gfx
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref

RADIUS = 3.0


def _locate(points, positions, tris):
    """For each point, the triangle containing it: (index, barycentric weights, plane distance)."""
    a, b, c = positions[tris[:, 0]], positions[tris[:, 1]], positions[tris[:, 2]]
    n = np.cross(b - a, c - a)
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 1e-12
    a, b, c, n, tri_ids = a[ok], b[ok], c[ok], n[ok] / area2[ok, None], np.flatnonzero(ok)
    out_idx = np.empty(len(points), int)
    out_w = np.empty((len(points), 3))
    out_d = np.empty(len(points))
    for k, p in enumerate(points):
        dist = np.sum((p - a) * n, axis=1)
        q = p - dist[:, None] * n  # projection on each plane
        wa = np.sum(np.cross(c - b, q - b) * n, axis=1)
        wb = np.sum(np.cross(a - c, q - c) * n, axis=1)
        wc = np.sum(np.cross(b - a, q - a) * n, axis=1)
        w = np.stack([wa, wb, wc], axis=1) / np.sum(np.cross(b - a, c - a) * n, axis=1)[:, None]
        inside = np.all(w >= -1e-5, axis=1)
        cand = np.flatnonzero(inside)
        best = cand[np.argmin(np.abs(dist[cand]))]
        out_idx[k], out_w[k], out_d[k] = tri_ids[best], w[best], dist[best]
    return out_idx, out_w, out_d


@pytest.fixture(scope="module")
def sphere():
    return gfx.sphere_geometry(RADIUS, 24, 16)


@pytest.fixture(scope="module")
def planet_blades(sphere):
    return gw.Blades.on_mesh(sphere, count=1536, seed=4, height=(0.5, 0.9), stiffness=(20.0, 30.0))


# ----------------------------------------------------------------- sampling


def test_sphere_roots_on_surface_and_up_equals_normals(sphere, planet_blades):
    b = planet_blades
    pos = sphere.positions.data.astype(np.float64)
    tris = sphere.indices.data.reshape(-1, 3).astype(np.int64)
    nrm = sphere.normals.data.astype(np.float64)
    idx, w, dist = _locate(b.v0.astype(np.float64), pos, tris)
    assert np.abs(dist).max() < 1e-5  # on a triangle of the mesh
    r = np.linalg.norm(b.v0, axis=1)
    assert r.max() <= RADIUS + 1e-5 and r.min() > 0.97 * RADIUS
    # up = interpolated vertex normal, normalised
    n = np.einsum("ki,kij->kj", w, nrm[tris[idx]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert np.abs(b.up - n).max() < 1e-5
    assert np.allclose(np.linalg.norm(b.up, axis=1), 1, atol=1e-6)
    assert np.min(np.sum(b.up * b.v0, axis=1) / r) > 0.99  # outward
    # the whole sphere is covered (both poles, all around)
    assert b.v0[:, 1].min() < -0.9 * RADIUS and b.v0[:, 1].max() > 0.9 * RADIUS


def test_sampling_is_by_area():
    # two triangles of area 1 and 3 (in the plane y = 0)
    positions = np.array([[0, 0, 0], [0, 0, 1], [2, 0, 0], [10, 0, 0], [10, 0, 2], [13, 0, 0]], np.float32)
    indices = np.array([[0, 1, 2], [3, 4, 5]], np.int32)
    b = gw.Blades.on_mesh((positions, indices), count=8000, seed=1)
    share = np.mean(b.v0[:, 0] >= 10)
    assert abs(share - 0.75) < 0.02
    assert np.allclose(b.v0[:, 1], 0)
    # density = blades per m^2: area 4
    assert len(gw.Blades.on_mesh({"positions": positions, "indices": indices}, density=50)) == 200


def test_face_normals_without_vertex_normals():
    # one tilted triangle, counter-clockwise seen from its front
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0.5, 0]), np.array([0.0, 0.2, -1])
    face = np.cross(b - a, c - a)
    face /= np.linalg.norm(face)
    bl = gw.Blades.on_mesh((np.array([a, b, c]), np.array([[0, 1, 2]])), count=300, seed=2)
    assert np.allclose(bl.up, face, atol=1e-6)
    assert np.allclose((bl.v0 - a) @ face, 0, atol=1e-6)  # in the triangle's plane
    flipped = gw.Blades.on_mesh((np.array([a, b, c]), np.array([[0, 2, 1]])), count=10, seed=2)
    assert np.allclose(flipped.up, -face, atol=1e-6)
    # non-indexed geometry: consecutive vertex triples
    assert len(gw.Blades.on_mesh((np.array([a, b, c]), None), count=5)) == 5


def test_vertex_normals_are_used():
    tilt = np.array([0.3, 1.0, -0.2])
    tilt /= np.linalg.norm(tilt)
    g = gfx.Geometry(
        positions=np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1]], np.float32),
        indices=np.array([[0, 1, 2]], np.int32),
        normals=np.tile(tilt, (3, 1)).astype(np.float32),
    )
    b = gw.Blades.on_mesh(g, count=50)
    assert np.allclose(b.up, tilt, atol=1e-6)


def test_blades_module_does_not_import_pygfx():
    code = (
        "import sys, numpy as np\n"
        "from grasswidget.core.blades import Blades\n"
        "b = Blades.on_mesh((np.eye(3), [[0, 1, 2]]), count=3)\n"
        "h = Blades.on_heightmap(np.zeros((2, 2)), 1.0, 3)\n"
        "assert 'pygfx' not in sys.modules and 'wgpu' not in sys.modules, 'GPU import'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_heightmap_bilinear_height_and_gradient_normal():
    # h = 0.1 x z + 0.3 x - 0.2 z + 1 is bilinear, so its samples interpolate it exactly
    size, rows, cols = 8.0, 9, 13
    x = np.linspace(-size / 2, size / 2, cols)
    z = np.linspace(-size / 2, size / 2, rows)
    X, Z = np.meshgrid(x, z)  # rows along z, columns along x
    H = 0.1 * X * Z + 0.3 * X - 0.2 * Z + 1.0
    b = gw.Blades.on_heightmap(H, size, 3000, seed=3)
    px, pz = b.v0[:, 0].astype(np.float64), b.v0[:, 2].astype(np.float64)
    assert np.abs(px).max() <= size / 2 and np.abs(pz).max() <= size / 2
    assert np.abs(b.v0[:, 1] - (0.1 * px * pz + 0.3 * px - 0.2 * pz + 1.0)).max() < 1e-5
    n = np.stack([-(0.1 * pz + 0.3), np.ones_like(px), -(0.1 * px - 0.2)], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert np.abs(b.up - n).max() < 1e-5


# ----------------------------------------------------------------- bad input


class _Geometry:
    """Duck-typed geometry (pygfx refuses to build an empty one)."""

    def __init__(self, positions, indices):
        self.positions = types.SimpleNamespace(data=positions)
        self.indices = types.SimpleNamespace(data=indices)


def test_bad_mesh_and_heightmap_input(sphere):
    empty = (np.zeros((0, 3)), np.zeros((0, 3), np.int32))
    with pytest.raises(ValueError, match="empty mesh"):
        gw.Blades.on_mesh(empty, count=10)
    with pytest.raises(ValueError, match="empty mesh"):  # only zero-area triangles
        gw.Blades.on_mesh((np.zeros((3, 3)), [[0, 1, 2]]), count=10)
    with pytest.raises(ValueError, match="empty mesh"):
        gw.Blades.on_mesh(_Geometry(np.zeros((3, 3), np.float32), np.zeros((0, 3), np.int32)), count=1)
    with pytest.raises(ValueError, match="exactly one of count"):
        gw.Blades.on_mesh(sphere)
    with pytest.raises(ValueError, match="exactly one of count"):
        gw.Blades.on_mesh(sphere, count=10, density=2.0)
    with pytest.raises(ValueError, match="density"):
        gw.Blades.on_mesh(sphere, density=-1.0)
    with pytest.raises(ValueError, match="density"):
        gw.Blades.on_mesh(sphere, density=1e-6)  # no blade at all
    with pytest.raises(ValueError, match="count"):
        gw.Blades.on_mesh(sphere, count=0)
    with pytest.raises(ValueError, match="positions must be finite"):
        gw.Blades.on_mesh((np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 1]]), [[0, 1, 2]]), count=3)
    with pytest.raises(ValueError, match="normals must be finite"):
        gw.Blades.on_mesh((np.eye(3), [[0, 1, 2]], np.full((3, 3), np.nan)), count=3)
    with pytest.raises(ValueError, match="indices must be in"):
        gw.Blades.on_mesh((np.eye(3), [[0, 1, 3]]), count=3)
    with pytest.raises(ValueError, match="indices must form triangles"):
        gw.Blades.on_mesh((np.eye(3), [0, 1]), count=3)
    with pytest.raises(TypeError, match="geometry"):
        gw.Blades.on_mesh("sphere", count=3)
    with pytest.raises(ValueError, match="height"):
        gw.Blades.on_mesh(sphere, count=3, height=(-1, 1))
    hm = np.zeros((4, 4))
    hm[1, 2] = np.nan
    with pytest.raises(ValueError, match="heights must be finite"):
        gw.Blades.on_heightmap(hm, 10.0, 100)
    with pytest.raises(ValueError, match="heights must be a 2D"):
        gw.Blades.on_heightmap(np.zeros((1, 5)), 10.0, 100)
    with pytest.raises(ValueError, match="size"):
        gw.Blades.on_heightmap(np.zeros((3, 3)), -1.0, 100)
    with pytest.raises(ValueError, match="count"):
        gw.Blades.on_heightmap(np.zeros((3, 3)), 1.0, 0)


# ----------------------------------------------------------------- a small planet on the GPU


@pytest.fixture(scope="module")
def planet(planet_blades):
    params = gw.GrassParams(
        gravity_mode="point", gravity_center=(0.0, 0.0, 0.0), wind_field="noise", wind_strength=25.0,
        wind_wavelength=2.0,
    )
    field = gw.GrassField(planet_blades, params=params)
    yield field
    field.release()


@pytest.mark.parametrize("steps", [1, 200])
def test_planet_gpu_matches_reference(planet, planet_blades, steps):
    planet.reset()
    planet.step(steps)
    gpu = planet.read_state()
    cpu = ref.simulate(planet_blades.rest_state(), planet.params, steps)
    err = max((np.linalg.norm(gpu[k] - cpu[k], axis=1) / planet_blades.height).max() for k in ("v1", "v2"))
    print(f"planet (point gravity, noise wind), {steps} steps: max |gpu - ref| / h = {err:.2e}")
    assert err < 1e-4


def test_planet_tips_never_sink_and_gravity_points_to_the_centre(planet, planet_blades, sphere):
    b = planet_blades
    pos = sphere.positions.data.astype(np.float64)
    tris = sphere.indices.data.reshape(-1, 3)
    a, bb, c = pos[tris[:, 0]], pos[tris[:, 1]], pos[tris[:, 2]]
    n = np.cross(bb - a, c - a)
    ok = np.linalg.norm(n, axis=1) > 1e-9
    inner = np.min(np.abs(np.sum(a[ok] * n[ok], axis=1)) / np.linalg.norm(n[ok], axis=1))  # inscribed radius

    planet.reset()
    p = planet.params
    p.gravity = 30.0
    try:
        for _ in range(4):
            planet.step(100)
            s = planet.read_state()
            assert np.all(np.isfinite(s["v2"]))
            rise = np.sum((s["v2"] - s["v0"]) * s["up"], axis=1)
            assert np.all(rise >= -1e-5 * b.height)  # never below the blade's ground plane
            assert np.linalg.norm(s["v2"], axis=1).min() >= inner - 1e-4  # never inside the planet
        # Gravity toward the centre: blades lean the same on every side of the planet,
        # unlike gravity along -y (which would pull the southern ones outward, straight).
        north, south = b.up[:, 1] > 0.7, b.up[:, 1] < -0.7
        rel = rise / b.height
        assert abs(rel[north].mean() - rel[south].mean()) < 0.05
        assert rel.mean() < 0.97  # and they do lean
        p.gravity_mode = "direction"
        planet.reset()
        planet.step(400)
        s = planet.read_state()
        rel_dir = np.sum((s["v2"] - s["v0"]) * s["up"], axis=1) / b.height
        assert rel_dir[south].mean() > rel_dir[north].mean() + 0.05
    finally:
        p.gravity, p.gravity_mode = 9.8, "point"


def test_culling_on_the_planet_matches_numpy(planet_blades):
    """Culling on a curved surface: each blade's own up and width direction; GPU
    decisions equal the NumPy reference blade for blade."""
    from test_culling import culling_mismatches

    params = gw.GrassParams(gravity_mode="point", wind_field="noise", wind_strength=25.0,
                            cull_distance_max=12.0, cull_buckets=8)
    scene = gw.GrassScene(planet_blades, size=(160, 120), params=params)
    scene.step(60)
    state = scene.field.read_state()
    seen = []
    for pos, target in (((0.0, 2.0, 9.0), (0.0, 0.0, 0.0)), ((6.0, 6.0, 2.0), (0.0, 1.0, 0.0)),
                        ((0.0, 4.5, 0.5), (0.0, 3.0, -2.0))):
        scene.camera.local.position = pos
        scene.camera.look_at(target)
        mismatch, _skip, drawn = culling_mismatches(scene, state, params)
        assert mismatch == 0
        seen.append(drawn.mean())
    # every test removes something somewhere, and something is always drawn
    assert all(0.0 < f < 0.95 for f in seen), seen
