"""The compute rasterizer of thin blades (GrassParams.compute_raster): the GPU's walk
against its NumPy reference blade for blade, and the picture with it against the
picture without it (at rest, while the camera moves, against a ball and a pygfx mesh)."""

import numpy as np
import pygfx as gfx
import pytest

import grasswidget as gw
from grasswidget import reference as ref
from grasswidget import teaching
from grasswidget.core.enums import BladeShape
from grasswidget.gpu.adapter import ensure_device
from grasswidget.gpu.compute import sync_buffer
from conftest import grass_mask, save_test_picture, shaded_grass_mask, sky_mask

SIZE = (192, 108)


@pytest.fixture(scope="module")
def meadow():
    sc = gw.GrassScene.preset("meadow", blades=1 << 14, size=SIZE, seed=2,
                              horizon=False)  # the dense square meadow (not the sparser field to the horizon)
    sc.params.compute_raster = True  # GrassScene's default is off on a CPU adapter (lavapipe here)
    yield sc
    sc.release()


def _on_off(scene):
    """(picture with the compute rasterizer, picture without, blades it drew): same state and camera."""
    p = scene.params
    p.compute_raster = True
    on = scene.render()
    rastered = scene.drawn_counts()["compute"]
    p.compute_raster = False
    off = scene.render()
    assert scene.drawn_counts()["compute"] == 0
    p.compute_raster = True
    return on, off, rastered


def _mean_difference(a, b, block=4):
    """Mean |a - b| (0..255) of the pictures' 4 x 4-pixel block means: the look. Pixel by
    pixel, two renders of sub-pixel grass differ in which blade wins each pixel (the
    ribbons' own LOD classes differ from full detail by 5.6 per pixel, 2.0 per block)."""
    h, w = a.shape[0] // block * block, a.shape[1] // block * block

    def blocks(x):
        return x[:h, :w, :3].astype(float).reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))

    return float(np.abs(blocks(a) - blocks(b)).mean())


def _read_u32(buffer):
    return np.frombuffer(ensure_device().queue.read_buffer(sync_buffer(buffer)), np.uint32)


def test_gpu_walk_matches_the_numpy_reference(meadow):
    """The depth and payload words the GPU wrote for the listed blades are
    reference.raster_blades of those blades (same clip-space control points)."""
    p = meadow.params
    p.compute_raster = True
    p.compute_raster_max_px = 3.0
    p.cull_occlusion = False  # one phase: the list is the whole frame's
    try:
        meadow.render()
        field = meadow.field
        ids = field.read_rastered()
        assert len(ids) > 1000
        w, h = field.raster_size
        assert (w, h) == SIZE
        depth, payload = field.read_raster_pixels()
        state = field.read_state()
        cam = meadow.camera
        mvp = (np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64)
               @ np.asarray(field.world.matrix, np.float64))
        shape = int(BladeShape.from_label(field.material.blade_shape))
        tau = field.material.tip_threshold
        # A few blades alone, each against the GPU's words where it won the pixel. A listed
        # blade may write no pixel at all (a sub-pixel span whose coverage draw gives 0
        # points, or a blade whose only points fall outside the view): those are skipped
        # here and checked with the rest in the whole-frame comparison below.
        wins = []
        sampled = ids[:: max(1, len(ids) // 80)][:80]
        for blade in sampled:
            if len(wins) == 24:
                break
            b = int(blade)
            c = [mvp @ np.append(state[k][b], 1.0) for k in ("v0", "v1", "v2")]
            across = mvp @ np.append(state["width"][b] * ref.width_direction(state["up"][b], state["orientation"][b]), 0.0)
            alone_depth, alone_payload = ref.raster_blades([(*c, across, b, shape, tau)], (w, h))
            ys, xs = np.nonzero(np.isfinite(alone_depth))
            if len(xs) == 0:
                continue
            won = (payload[ys, xs] >> 8) == b
            wins.append(won.mean())
            ds = alone_depth[ys, xs]
            assert np.allclose(depth[ys, xs].view(np.float32)[won], ds[won], atol=2e-6)
            assert np.all(np.abs((payload[ys, xs][won] & 255).astype(int) - (alone_payload[ys, xs][won] & 255)) <= 1)
            # where another blade won, it is nearer
            assert np.all(depth[ys, xs][~won].view(np.float32) <= ds[~won] + 2e-6)
        assert len(wins) == 24  # most listed blades write pixels
        assert sum(w > 0 for w in wins) >= 4  # blades that show somewhere (the rest: behind nearer ones)
        # All listed blades together: the covered pixels are the reference's.
        # (the same clip-space points as above, for all listed blades at once)
        listed = ids.astype(np.int64)
        clip = {k: np.c_[state[k][listed], np.ones(len(listed))] @ mvp.T for k in ("v0", "v1", "v2")}
        t1 = ref.width_direction(state["up"][listed], state["orientation"][listed])
        across_all = np.c_[state["width"][listed][:, None] * t1, np.zeros(len(listed))] @ mvp.T
        blades = [(clip["v0"][i], clip["v1"][i], clip["v2"][i], across_all[i], int(b), shape, tau)
                  for i, b in enumerate(listed)]
        ref_depth, ref_payload = ref.raster_blades(blades, (w, h))
        gpu_covered = depth != ref.RASTER_EMPTY
        ref_covered = np.isfinite(ref_depth)
        assert gpu_covered.sum() > 2000
        # float32 rounding may move a point across a pixel border: a few pixels differ
        assert (gpu_covered ^ ref_covered).sum() <= 0.01 * ref_covered.sum()
        both = gpu_covered & ref_covered
        assert np.mean(np.abs(depth[both].view(np.float32) - ref_depth[both]) < 1e-5) > 0.98
        assert np.mean(payload[both] >> 8 == ref_payload[both] >> 8) > 0.95
    finally:
        p.compute_raster_max_px = gw.GrassParams().compute_raster_max_px
        p.cull_occlusion = True


def test_one_walk_and_two_walks_write_the_same_pixels(meadow):
    """The one walk (64-bit atomics, where the device has them: lavapipe does) and the two walks
    (the browser engine's layout, forced here with raster_walks.prefer_two_walks) keep the same
    winner in every pixel: the same depth and payload words, and the same picture."""
    from grasswidget.gpu import raster_walks

    if not meadow.field.raster_packed:
        pytest.skip("this device has no 64-bit atomics: only the two walks run here")
    raster_walks.prefer_two_walks(True)
    try:
        two = gw.GrassScene.preset("meadow", blades=1 << 14, size=SIZE, seed=2, horizon=False)
    finally:
        raster_walks.prefer_two_walks(False)
    try:
        assert not two.field.raster_packed and meadow.field.raster_packed
        meadow.field.reset()  # the blades at rest, as in the new scene (earlier tests may have stepped them)
        meadow.reset_camera()
        pictures, words = [], []
        for scene in (meadow, two):
            p = scene.params
            p.compute_raster, p.compute_raster_max_px, p.cull_occlusion = True, 3.0, False
            pictures.append(scene.render())
            words.append(scene.field.read_raster_pixels())
            p.compute_raster_max_px, p.cull_occlusion = gw.GrassParams().compute_raster_max_px, True
        (depth1, payload1), (depth2, payload2) = words
        assert (depth1 != ref.RASTER_EMPTY).sum() > 2000
        assert np.array_equal(depth1, depth2)
        assert np.array_equal(payload1, payload2)
        assert np.array_equal(pictures[0], pictures[1])
    finally:
        two.release()


def _covered_rows(field):
    """(first, last) pixel row holding a compute-rasterized word, from the depth words read back."""
    rows = np.nonzero((field.read_raster_pixels()[0] != ref.RASTER_EMPTY).any(axis=1))[0]
    return (int(rows[0]), int(rows[-1])) if len(rows) else None


def test_rows_written_bound_the_clear_and_the_resolve(meadow):
    """The walks record the pixel rows they wrote (s_raster_args[2] and the complement in [3]);
    the next frame clears only those rows and the resolve draws only them. After the camera
    tilts (the far, thin blades move up or down the view), the words left are exactly this
    frame's: the rows recorded are the rows holding words, none left over from the frame before.
    A new size (new pixel words) is cleared whole."""
    p = meadow.params
    p.compute_raster = True
    p.compute_raster_max_px = 3.0
    p.cull_occlusion = False
    home = np.array(meadow.camera.local.position)
    try:
        seen = []
        for lift in (-6.0, 2.0, -6.0):  # the view's centre low, high, low again: the band moves
            meadow.camera.look_at(tuple(home + (0.0, lift, -30.0)))
            meadow.render()
            field = meadow.field
            args = _read_u32(field.raster_args_buffer)
            recorded = (int(args[2]), int(~args[3] & 0xFFFFFFFF))
            assert recorded == _covered_rows(field)
            assert field.read_raster_count() > 100
            seen.append(recorded)
        assert seen[0] != seen[1] and seen[0] == seen[2]
        assert seen[1][0] > seen[0][1] or seen[1][1] < seen[0][0] or seen[1][0] != seen[0][0]
        # Another size: new words, cleared whole on their first frame; back: the same again.
        small = meadow.render_at((SIZE[0] // 2, SIZE[1] // 2), antialias=False)
        assert small.shape[:2] == (SIZE[1] // 2, SIZE[0] // 2)
        meadow.render()
        args = _read_u32(meadow.field.raster_args_buffer)
        assert (int(args[2]), int(~args[3] & 0xFFFFFFFF)) == _covered_rows(meadow.field) == seen[2]
    finally:
        p.compute_raster_max_px = gw.GrassParams().compute_raster_max_px
        p.cull_occlusion = True
        meadow.reset_camera()


def test_walk_reference_covers_a_curve_without_gaps():
    """Bent blades seen face on: every pixel row between root and tip is written (no
    gaps where the curve is fast or slow on screen), and the pixels written are about
    the blade's area (sub-pixel widths included: coverage, not a 1-pixel line)."""
    size = (200, 200)
    c0 = np.array([0.0, -0.6, 0.5, 1.0])
    c1 = np.array([0.0, 0.3, 0.5, 1.0])  # v1 high above the root: fast at the root, slow at the tip
    c2 = np.array([0.25, 0.4, 0.5, 1.0])
    length = 116.0  # pixels along the curve (about)
    for width_px in (0.4, 0.8, 1.0, 2.0, 3.0):
        across = np.array([width_px / size[0], 0.0, 0.0, 0.0])  # full width width_px pixels
        written = []
        for blade in range(40):
            xs, ys, ds, vs = ref.raster_walk(c0, c1, c2, across, blade, int(BladeShape.QUAD), 0.5, size)
            written.append(len(set(zip(xs, ys))))
            if width_px >= 1.0:
                assert set(range(ys.min(), ys.max() + 1)) == set(ys)  # no row missing
            assert np.allclose(ds, 0.5)
        assert np.mean(written) == pytest.approx(width_px * length, rel=0.2), width_px


def test_picture_at_rest_is_the_hardware_one(meadow):
    """Grass is counted by its hue here and below (conftest.shaded_grass_mask): the two paths cover the
    same blades, and the compute path's darker far grass (sub-pixel blades it covers whole) or the
    sunlight's shade (on by default on a GPU) must not count as less coverage."""
    meadow.field.reset()  # at rest, whatever the tests before did
    meadow.reset_camera()
    on, off, rastered = _on_off(meadow)
    assert rastered > 0.3 * meadow.visible_count()
    assert _mean_difference(on, off) < 3.5
    # no holes: where the ribbons draw grass, so does the compute path (per row: the far
    # rows are the compute-drawn ones; sub-pixel coverage differs pixel by pixel)
    rows_on, rows_off = shaded_grass_mask(on).mean(axis=1), shaded_grass_mask(off).mean(axis=1)
    assert np.all(rows_on >= rows_off - 0.15)
    # never less grass; a little more (the LOD ribbons' 1-segment blades are narrower at the top)
    assert -0.01 < shaded_grass_mask(on).mean() - shaded_grass_mask(off).mean() < 0.08


def _coverage_change(a, b, block=4):
    """Mean over the pictures' 4 x 4-pixel blocks of |grass coverage of a - grass coverage of b|
    (fractions, 0..1): how much of each block one path covers with grass and the other does not."""
    h, w = a.shape[0] // block * block, a.shape[1] // block * block

    def coverage(x):
        return grass_mask(x)[:h, :w].astype(float).reshape(h // block, block, w // block, block).mean(axis=(1, 3))

    return float(np.abs(coverage(a) - coverage(b)).mean())


def _grass_ground_contrast(img):
    """|mean grass colour - mean ground colour| of a picture (0..255, the channels averaged): what a
    pixel changes by when a blade covers the ground behind it."""
    rgb = img[..., :3].astype(float)
    grass = grass_mask(img)
    ground = ~grass & ~sky_mask(img)
    return float(np.abs(rgb[grass].mean(axis=0) - rgb[ground].mean(axis=0)).mean())


def test_picture_while_the_camera_moves(meadow):
    """The camera moves each frame with occlusion culling on (compute-drawn blades go
    through both phases and into the depth pyramid) and the wind blows.

    The bound on the look (mean block difference, on vs off) comes from what the two paths may
    differ in. Both draw the same blades at the same depths with the same shading; they differ in
    sub-pixel coverage only: which blade wins a pixel, and grass where the LOD ribbons leave gaps
    (their 1-segment blades are narrower at the top) that the compute path, which covers a blade's
    area, fills. The first is the difference at the home camera in the same wind (frame 0:
    ``base``; the wind bends blades over each other, so it is larger than at rest: 3.7 against 3.3
    on lavapipe). For the second, a block whose grass coverage grows by a fraction f changes by
    f x the contrast C between grass and the ground behind it. So a frame whose camera moved differs
    by at most ``base + max(0, its coverage change - frame 0's) x C`` (coverage changes per 4 x 4
    block, C from the picture without the compute path). Measured on lavapipe: 4.2-4.6 against
    bounds of 4.7-5.9."""
    meadow.reset_camera()
    meadow.params.wind_strength = 12.0
    home = np.array(meadow.camera.local.position)
    # the bare plain beyond the field (far_grass.w = 0), not the far grass: the bound tells blades from the
    # ground by their colour (grass_mask), and the far grass is green too
    material = meadow.sky_ground.material
    far = tuple(float(x) for x in material.uniform_buffer.data["far_grass"])
    material.set_values({"far_grass": (*far[:3], 0.0)})
    try:
        for k in range(4):
            meadow.camera.local.position = tuple(home + (1.5 * k, 0.4 * k, -2.0 * k))
            meadow.camera.look_at(tuple(home + (1.5 * k + 0.5, -2.0, -20.0)))
            meadow.step(4)
            on, off, rastered = _on_off(meadow)
            save_test_picture(f"compute_raster_moving_{k}", np.concatenate([on, off], axis=1))
            assert rastered > 0
            difference, coverage = _mean_difference(on, off), _coverage_change(on, off)
            if k == 0:  # the home camera: the baseline of the frames that moved
                base, base_coverage = difference, coverage
            bound = base + max(0.0, coverage - base_coverage) * _grass_ground_contrast(off)
            assert difference <= bound, (k, difference, base, bound)
            # no holes: never less grass; a little more (the LOD ribbons' 1-segment blades are narrower at the top)
            assert -0.01 < shaded_grass_mask(on).mean() - shaded_grass_mask(off).mean() < 0.08
    finally:
        material.set_values({"far_grass": far})
        meadow.params.wind_strength = gw.GrassParams().wind_strength
        meadow.reset_camera()


def _red_mask(img):
    rgb = img[..., :3].astype(int)
    return (rgb[..., 0] > 120) & (rgb[..., 1] < 60) & (rgb[..., 2] < 60)


def test_depth_against_a_pygfx_mesh(meadow):
    """An opaque red box standing in the far grass: its lower part is hidden by the
    compute-drawn blades in front of it, and it hides the blades behind it, as with ribbons."""
    meadow.reset_camera()
    cam = np.array(meadow.camera.local.position)
    forward = -np.asarray(meadow.camera.world.matrix, np.float64)[:3, 2]
    forward[1] = 0.0
    forward /= np.linalg.norm(forward)
    box = gfx.Mesh(gfx.box_geometry(3.0, 1.2, 0.3), gfx.MeshBasicMaterial(color="#ff0000"))
    centre = cam + 30.0 * forward
    box.local.position = (centre[0], 0.6, centre[2])
    meadow.scene.add(box)
    try:
        on, off, rastered = _on_off(meadow)
        red_on, red_off = _red_mask(on), _red_mask(off)
        assert red_off.sum() > 20
        # the box's pixels are the same: grass in front of its foot covers it in both
        assert (red_on ^ red_off).sum() <= 0.15 * red_off.sum()
        rows = np.flatnonzero(red_off.any(axis=1))
        foot = rows[-3:]  # the box's lowest rows: grass in front hides part of them
        assert red_on[foot].mean() < 0.9 and red_off[foot].mean() < 0.9
        # and no blade behind the box shows through it: its upper rows are solid red
        top = rows[: max(len(rows) // 3, 1)]
        cols = np.flatnonzero(red_off[top].all(axis=0))
        assert len(cols) > 3 and red_on[np.ix_(top, cols)].all()
    finally:
        meadow.scene.remove(box)


def test_depth_against_a_ball(meadow):
    """A collider ball sunk into the far grass is drawn over what is behind it and
    under the compute-drawn blades in front of it, as with ribbons."""
    meadow.reset_camera()
    cam = np.array(meadow.camera.local.position)
    forward = -np.asarray(meadow.camera.world.matrix, np.float64)[:3, 2]
    forward[1] = 0.0
    forward /= np.linalg.norm(forward)
    centre = cam + 25.0 * forward
    meadow.colliders = [gw.SphereCollider((centre[0], 0.3, centre[2]), 1.0)]
    try:
        on, off, _ = _on_off(meadow)
        meadow.show_colliders = False
        no_ball = meadow.render()
        meadow.show_colliders = True
        ball_on = np.abs(on[..., :3].astype(int) - no_ball[..., :3].astype(int)).max(axis=2) > 24
        meadow.params.compute_raster = False
        meadow.show_colliders = False
        no_ball_off = meadow.render()
        meadow.show_colliders = True
        meadow.params.compute_raster = True
        ball_off = np.abs(off[..., :3].astype(int) - no_ball_off[..., :3].astype(int)).max(axis=2) > 24
        assert ball_off.sum() > 30
        assert (ball_on ^ ball_off).sum() <= 0.2 * ball_off.sum()
    finally:
        meadow.colliders = []


def test_teaching_colour_and_counts(meadow):
    """color_by "lod": the compute-drawn blades are flat in COMPUTE_RASTER_COLOR; the
    counts of both paths add up to the blades drawn without it."""
    meadow.reset_camera()
    p = meadow.params
    p.cull_occlusion = False
    try:
        p.color_by = "lod"
        img = meadow.render()
        white = (img[..., :3] >= 250).all(axis=2)
        counts = meadow.drawn_counts()
        assert counts["compute"] > 0 and white.mean() > 0.01
        p.compute_raster = False
        img_off = meadow.render()
        assert (img_off[..., :3] >= 250).all(axis=2).mean() < 0.2 * white.mean()
        assert meadow.drawn_counts()["hardware"] == counts["hardware"] + counts["compute"]
        assert teaching.legend("lod")[-1][1] == teaching.COMPUTE_RASTER_COLOR
    finally:
        p.color_by = "natural"
        p.compute_raster = True
        p.cull_occlusion = True



def test_steps_skipped_while_off_and_the_picture_after_it_is_on_again(meadow):
    """While the compute rasterizer is off its compute steps dispatch nothing (gpu/indirect.py's
    skip_dispatch); switched on again, its first picture is the one from before it was off.

    Its blade count is compared without occlusion culling: with it, which blades a frame draws
    depends on the frame before (its first phase draws the blades seen last frame, and the
    pyramid the second phase tests against holds only their depths), so the count after frames
    without the rasterizer may differ by a few blades from one after frames with it, at the same
    picture (test_occlusion.py)."""
    from grasswidget.gpu.shader_classes import RasterShader

    meadow.reset_camera()
    p = meadow.params
    was = p.cull_occlusion
    for occlusion in (False, True):
        p.cull_occlusion = occlusion
        try:
            first, off, rastered = _on_off(meadow)
            assert rastered > 0 and not np.array_equal(first, off)
            p.compute_raster = False
            meadow.render()
            assert RasterShader(meadow.field, "clear_args").skip_dispatch()
            p.compute_raster = True
            again = meadow.render()
            assert not RasterShader(meadow.field, "clear_args").skip_dispatch()
            if not occlusion:
                assert meadow.drawn_counts()["compute"] == rastered
            assert np.abs(again.astype(int) - first).max() <= 1
        finally:
            p.cull_occlusion = was
            p.compute_raster = True
