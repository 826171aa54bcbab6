"""GPU culling, LOD binning and indirect draw against an independent NumPy computation."""

import numpy as np
import pytest
from traitlets import TraitError

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.gpu import indirect
from grasswidget.gpu.adapter import is_cpu_adapter
from conftest import grass_mask


# Fixture scene (conftest).
SCENE = dict(preset="cis565", blades=3000, size=(160, 120), seed=5)


def _camera_matrices(scene):
    cam = scene.camera
    view_proj = np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64)
    return view_proj, np.asarray(cam.world.position, np.float64)


def _set(params, **kw):
    """Set culling params; occlusion culling off unless asked (these tests compare the
    other tests with reference.cull; tests/test_occlusion.py covers occlusion)."""
    kw.setdefault("cull_occlusion", False)
    for k, v in kw.items():
        setattr(params, k, v)


def _near_threshold(state, params, view_proj, cam_pos, eps=1e-4):
    """Blades within eps of any culling threshold (excluded from exact comparison)."""
    v0, v1, v2, up = (state[k].astype(np.float64) for k in ("v0", "v1", "v2", "up"))
    t1 = ref.width_direction(up, state["orientation"])
    d = v0 - cam_pos
    o = np.abs(np.sum(d / np.linalg.norm(d, axis=1)[:, None] * t1, axis=1))
    near = np.abs(o - params.cull_orientation_threshold) < eps
    m = 0.25 * v0 + 0.5 * v1 + 0.25 * v2
    for p in (v0, m, v2):
        c = np.concatenate([p, np.ones((len(p), 1))], 1) @ view_proj.T
        lim = c[:, 3] + params.cull_frustum_tolerance
        for val in (np.abs(c[:, 0]) - lim, np.abs(c[:, 1]) - lim, c[:, 2], c[:, 2] - c[:, 3]):
            near |= np.abs(val) < eps * np.maximum(1.0, np.abs(c[:, 3]))
    dproj = np.linalg.norm(d - up * np.sum(d * up, axis=1)[:, None], axis=1)
    x = params.cull_buckets * np.maximum(1 - dproj / params.cull_distance_max, 0)
    near |= np.abs(x - np.round(x)) < eps * params.cull_buckets
    return near


def culling_mismatches(scene, state, params):
    """Render with the scene's camera; (blades where the GPU's decision differs from
    reference.cull, blades near a threshold that are left out, GPU drawn mask)."""
    scene.render()
    view_proj, cam_pos = _camera_matrices(scene)
    expected = ref.cull(state, params, view_proj, cam_pos)
    drawn = np.zeros(len(expected), bool)
    drawn[scene.field.read_visible()] = True
    skip = _near_threshold(state, params, view_proj, cam_pos)
    return int(((drawn != expected) & ~skip).sum()), int(skip.sum()), drawn


def _random_camera(scene, rng):
    ang = rng.uniform(0, 2 * np.pi)
    r = rng.uniform(4, 25)
    pos = (r * np.cos(ang), rng.uniform(0.5, 8), r * np.sin(ang))
    scene.camera.local.position = pos
    scene.camera.look_at((rng.uniform(-5, 5), rng.uniform(0, 1.5), rng.uniform(-5, 5)))


@pytest.mark.parametrize("tests", ["all", "orientation", "frustum", "distance"])
def test_culling_matches_numpy_on_random_cameras(scene, tests):
    rng = np.random.default_rng(42)
    p = scene.params
    _set(p, cull_orientation=tests in ("all", "orientation"), cull_frustum=tests in ("all", "frustum"),
         cull_distance=tests in ("all", "distance"), cull_distance_max=30.0, cull_buckets=10)
    try:
        scene.field.reset()
        p.wind_strength = 30
        scene.step(60)
        state = scene.field.read_state()
        for _ in range(4):
            _random_camera(scene, rng)
            mismatch, skip, drawn = culling_mismatches(scene, state, p)
            assert mismatch == 0, f"{mismatch} blades differ ({skip} near a threshold)"
            assert scene.visible_count() == drawn.sum()
    finally:
        _set(p, cull_orientation=True, cull_frustum=True, cull_distance=True, cull_distance_max=100.0,
             cull_buckets=100, wind_strength=5.0)
        scene.reset_camera()


#: A blade may be in another LOD class than the reference's only when its projected height lies
#: within this relative distance of a class boundary (reference.LOD_MIN_PIXELS): the GPU computes
#: it in float32 (a few ulp: ~1e-6 relative), the reference in float64. (Blades drawn by the
#: compute rasterizer are in no class: see tests/notebook/test_crossing_matrix.py and notebook 03.)
LOD_BOUNDARY_REL = 1e-4


@pytest.mark.parametrize("compute_raster", [False, True])
def test_lod_classes_match_numpy(scene, compute_raster):
    p = scene.params
    before = p.compute_raster
    _set(p, cull_orientation=False, cull_distance=False, compute_raster=compute_raster)
    try:
        scene.field.reset()
        scene.camera.local.position = (0, 6, 22)
        scene.camera.look_at((0, 0, 0))
        scene.render()
        state = scene.field.read_state()
        view_proj, cam_pos = _camera_matrices(scene)
        args = scene.field.read_draw_args()
        expected = ref.lod_class(state["v0"], state["v2"], state["height"], view_proj, scene.size[1])
        visible = ref.cull(state, p, view_proj, cam_pos)
        gpu = np.full(len(expected), -1)
        for k, ids in enumerate(scene.field.read_visible(draw_order=True)):
            gpu[ids] = k
        in_compute = scene.field.read_rastered()
        ribbons = np.flatnonzero(gpu >= 0)
        # every blade the reference keeps is drawn once: in one class, or in compute (in no class)
        assert not np.isin(in_compute, ribbons).any()
        assert np.array_equal(np.sort(np.concatenate([ribbons, in_compute])), np.flatnonzero(visible))
        assert len(ribbons) == int(args[:, 1].sum())
        pixels = ref.projected_pixels(state["v0"], state["v2"], state["height"], view_proj, scene.size[1])
        bounds = np.array([b for b in ref.LOD_MIN_PIXELS if b > 0])
        near = np.min(np.abs(pixels[:, None] / bounds - 1.0), axis=1) < LOD_BOUNDARY_REL
        moved = (gpu >= 0) & (gpu != expected)
        assert not np.any(moved & ~near), f"{int(np.sum(moved & ~near))} blades in another class away from a boundary"
        counts = np.bincount(expected[visible], minlength=len(ref.LOD_SEGMENTS))
        assert (counts > 0).sum() >= 2  # the view spans several classes
        assert len(in_compute) > 0 if compute_raster else len(in_compute) == 0
        assert list(args[:, 0]) == [2 * (s + 1) for s in ref.LOD_SEGMENTS]
    finally:
        _set(p, cull_orientation=True, cull_distance=True, compute_raster=before)
        scene.reset_camera()


def test_orientation_culling_removes_about_29_percent_from_the_side():
    b = gw.Blades.on_plane(20000, size=2.0, seed=8)
    sc = gw.GrassScene(b, size=(64, 48))
    p = sc.params
    _set(p, cull_frustum=False, cull_distance=False, cull_orientation=True)
    sc.camera.local.position = (0, 1.0, 200)  # far to the side, at blade height
    sc.camera.look_at((0, 1.0, 0))
    sc.render()
    frac = 1 - sc.visible_count() / len(b)
    assert 0.26 < frac < 0.32, frac  # 2 arccos(0.9) / pi = 0.287, not 0.713


def test_camera_facing_away_draws_nothing(scene):
    scene.camera.local.position = (0, 1, 10)
    scene.camera.look_at((0, 1, 30))
    try:
        scene.render()
        assert scene.visible_count() == 0
    finally:
        scene.reset_camera()


def test_frustum_culling_does_not_change_the_picture(scene):
    p = scene.params
    _set(p, cull_orientation=False, cull_distance=False, lod=False)
    try:
        scene.field.reset()
        scene.step(30)
        for pos, target in [((0, 1, 10), (0, 1, 0)), ((6, 3, 4), (-3, 0, -4))]:
            scene.camera.local.position = pos
            scene.camera.look_at(target)
            p.cull_frustum = False
            a = scene.render()
            n_all = scene.visible_count()
            p.cull_frustum = True
            b = scene.render()
            n_some = scene.visible_count()
            diff = np.any(a != b, axis=-1).mean()
            assert diff < 1e-3, diff
            assert grass_mask(a).mean() > 0.1
        assert n_some < n_all  # the second view really culled something
    finally:
        _set(p, cull_orientation=True, cull_distance=True, lod=True, cull_frustum=True)
        scene.reset_camera()


def test_toggling_changes_count_without_pipeline_rebuild(scene):
    for _ in range(3):  # a still view: from the third frame its sky and ground are copied (SkyGroundCache)
        scene.render()
    assert scene.sky_ground.material.copied
    containers = _containers(scene)
    pipelines = [c.wgpu_pipeline for c in containers]
    counts = []
    for on in (True, False, True):
        scene.params.cull_orientation = on
        scene.render()
        counts.append(scene.visible_count())
    assert counts[0] < counts[1] and counts[0] == counts[2]
    assert [c.wgpu_pipeline for c in _containers(scene)] == pipelines


def _containers(scene):
    """The pipeline containers used by one render of the scene (caught with spies)."""
    from pygfx.renderers.wgpu.engine import pipeline

    seen = []
    orig_draw, orig_dispatch = indirect.IndirectRenderPipelineContainer.draw, pipeline.ComputePipelineContainer.dispatch

    def draw(self, *args):
        seen.append(self)
        return orig_draw(self, *args)

    def dispatch(self, *args):
        seen.append(self)
        return orig_dispatch(self, *args)

    indirect.IndirectRenderPipelineContainer.draw = draw
    pipeline.ComputePipelineContainer.dispatch = dispatch
    try:
        scene.render()
    finally:
        indirect.IndirectRenderPipelineContainer.draw = orig_draw
        pipeline.ComputePipelineContainer.dispatch = orig_dispatch
    return seen


def test_drawn_count_equals_gpu_counter(scene):
    scene.render()
    args = scene.field.read_draw_args()
    assert len(scene.field.read_visible()) == args[:, 1].sum() == scene.visible_count()
    assert scene.visible_count() > 0


def test_indirect_patch_is_live(scene):
    """Fails loudly if a pygfx upgrade stops using our indirect container."""
    assert indirect.is_installed()
    # one draw per LOD class, and one of the culled blades (color_by "cull"); with occlusion culling on, as
    # many again for its second phase
    per_phase = len(ref.LOD_SEGMENTS) + 1
    for occlusion, expected in ((True, 2 * per_phase), (False, per_phase)):
        scene.params.cull_occlusion = occlusion
        scene.render()  # the switch's pipelines and children settled
        used = _containers(scene)
        # each container once (the second phase's draws are called in the first render, deferred, and again
        # in the second phase's submission); the rasterizer's walks dispatch indirectly too
        draws = list({id(c): c for c in used if hasattr(c, "shader")
                      and getattr(c.shader, "indirect_args", None) is not None
                      and not isinstance(c, indirect.IndirectComputePipelineContainer)}.values())
        assert len(draws) == expected, (f"pygfx no longer draws the grass through the indirect container "
                                        f"(occlusion {occlusion}: {len(draws)} draws, {expected} expected)")
        assert all(isinstance(c, indirect.IndirectRenderPipelineContainer) for c in draws)
    # the args buffer really drives the draw: zero instances -> no grass on screen (the ground hidden: its far
    # grass beyond the field is green too)
    from conftest import grass_mask

    scene.ground.visible = False
    try:
        img = scene.render()
        assert grass_mask(img).mean() > 0.05
        scene.params.cull_distance_max = 0.01  # everything culled by distance
        img = scene.render()
        assert scene.visible_count() == 0 and grass_mask(img).mean() < 0.01
    finally:
        scene.params.cull_distance_max = 100.0
        scene.ground.visible = True


def test_stats_are_non_blocking_and_converge(scene):
    st = scene.stats
    for _ in range(6):
        scene.step(1)
        scene.render()
    st.poll()
    assert st.visible is not None and abs(st.visible - scene.visible_count()) <= scene.field.count
    assert len(st.visible_per_class) == len(ref.LOD_SEGMENTS)
    assert st.render_ms > 0
    assert st.counts_frame is None or st.counts_frame <= st.frames


def test_settled_stats_are_the_last_frames_counts(scene):
    """After settle() the stats' counts are those of the last render (its frame number), the same
    as the synchronous readbacks, for each camera of a moving view; occluded is None for a frame
    that ran without occlusion culling and the GPU's count for one with it."""
    p = scene.params
    st = scene.stats
    before = p.cull_occlusion
    try:
        for k, occlusion in enumerate([False, True, True, False]):
            p.cull_occlusion = occlusion
            scene.camera.local.position = (2.0 * k - 3.0, 1.5, 12.0)
            scene.camera.look_at((0, 0.3, 0))
            scene.render()
            st.settle()
            assert st.counts_frame == st.frames
            assert st.visible == scene.visible_count() and st.rastered == scene.drawn_counts()["compute"]
            assert sum(st.visible_per_class) == scene.drawn_counts()["hardware"]
            assert st.occluded == (scene.field.read_occluded_count() if occlusion else None)
    finally:
        p.cull_occlusion = before
        scene.reset_camera()


def test_stats_before_the_first_step():
    """Rendering before any step() works and reports no simulation time (the
    simulation's timestamp queries hold no measurement yet; resolving never-written
    queries hung NVIDIA's driver, so FrameStats writes them once at creation)."""
    sc = gw.GrassScene(512, size=(64, 48))
    st = sc.stats
    for _ in range(4):
        sc.render()
    st.poll()
    sc.field.read_state()  # waits for the queue: the stats copies are done
    st.poll()
    assert st.visible == sc.visible_count() > 0
    assert "simulation" not in st.gpu_ms
    sc.step(1)
    sc.render()
    sc.field.read_state()
    st.poll()
    sc.render()
    sc.field.read_state()
    st.poll()
    # measured with timestamps on a GPU adapter; never on a CPU adapter, whose compute timestamps read a
    # fraction of the step's time (FrameStats.simulation_timed): no number rather than a wrong one
    assert st.simulation_timed == (st.timestamps and not is_cpu_adapter())
    if st.simulation_timed:
        assert st.gpu_ms.get("simulation", 0) > 0
    else:
        assert "simulation" not in st.gpu_ms


@pytest.mark.parametrize(
    "name, value",
    [("cull_orientation_threshold", 1.5), ("cull_orientation_threshold", -0.1), ("cull_buckets", 0),
     ("cull_distance_max", -5.0), ("cull_frustum_tolerance", float("nan"))],
)
def test_bad_culling_params(name, value):
    p = gw.GrassParams()
    with pytest.raises(TraitError, match=name):
        setattr(p, name, value)


@pytest.mark.parametrize("switches", ["culling and LOD on", "LOD off", "culling and LOD off"])
def test_draws_run_nearest_first_whatever_the_switches(switches):
    """Every class's list runs through the distance bands nearest first (front-to-back
    draws, so the depth test rejects hidden fragments before they are shaded), with LOD
    and culling on, with LOD off, and with every culling test off; the set of drawn
    blades is the one the culling tests keep, whatever the order."""
    from grasswidget.gpu.shader_classes import BAND_RANGE, DISTANCE_BANDS

    scene = gw.GrassScene.preset("cis565", blades=4096)
    if switches != "culling and LOD on":
        scene.params.lod = False
    if switches == "culling and LOD off":
        for name in ("cull_orientation", "cull_frustum", "cull_distance", "cull_occlusion"):
            setattr(scene.params, name, False)
    scene.render()
    lists = scene.field.read_visible(draw_order=True)
    cam = np.asarray(scene.camera.world.position, np.float64)
    v0 = scene.field.blades.v0.astype(np.float64)  # the field's local space is the world here
    lo, hi = BAND_RANGE
    d = np.maximum(np.linalg.norm(v0 - cam, axis=1), lo)
    band = np.clip(np.floor(DISTANCE_BANDS * np.log2(d / lo) / np.log2(hi / lo)), 0, DISTANCE_BANDS - 1)
    drawn = 0
    for ids in lists:
        b = band[ids]
        near_edge = np.abs(DISTANCE_BANDS * np.log2(d[ids] / lo) / np.log2(hi / lo) - np.round(b)) < 1e-3
        steps = np.diff(b)
        assert np.all((steps >= 0) | near_edge[1:] | near_edge[:-1]), "a farther band before a nearer one"
        drawn += len(ids)
    assert drawn > 500 and len({int(x) for ids in lists for x in band[ids]}) > 3
    assert np.array_equal(np.sort(np.concatenate(lists)), scene.field.read_visible())
    if switches == "culling and LOD off":
        assert drawn == scene.field.count, "with every test off every blade is drawn"
