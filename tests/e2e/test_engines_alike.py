"""The kernel and browser engines give the same pictures and counts, in a real JupyterLab + Chromium (WebGPU on SwiftShader).

* The two engines on equal terms: the same blades, parameters (the looks on: patches,
  dry grass, sunlit tips, fog), steps and camera give the same picture, saved with
  ``save_png`` from a browser widget (anti-aliased in the browser: rendered 2x and
  filtered down as pygfx does) and by the kernel engine (a GrassScene on lavapipe).
  The mean absolute difference is printed and bounded, the ground beyond the field
  matches the NumPy twins in both; both pictures are written side by side (kernel left, browser right)
  to ``engines_side_by_side.png`` in ``$GW_ARTIFACTS_DIR`` (else the Lab root's
  ``artifacts`` folder).
* The same with the sunlight on (GrassParams.shadows, a low sun, a ball's shadow):
  ``sunlit_side_by_side.png``; switched on and off again at run time (each engine builds the draws
  with or without the sunlight's maths), the pictures without it agree too.
* The meadow to the horizon (``Blades.on_plane(..., reach=R)``: thinned, widened far blades and
  the far ground coloured like them) is drawn alike too: the same blades, steps and a camera
  looking far give pictures within the same bound, and the band under the horizon is grass in
  both (``engines_horizon_side_by_side.png``).
* One simulation per widget: a widget displayed twice has one engine in the page
  with two views; while it plays and after it pauses, both canvases show the same
  meadow, and ``step`` / ``read_state`` have one answer.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np
import pytest

from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook
from .polling import poll

pytestmark = pytest.mark.browser

N_BLADES = 2048
SIZE = (320, 240)



def _artifacts(root):
    out = os.environ.get("GW_ARTIFACTS_DIR") or str(root / "artifacts")
    os.makedirs(out, exist_ok=True)
    return out


#: A canvas's frames drawn, and whether some pixel of it is inside the viewport now.
_DRAWN_AND_SEEN = """c => { const r = c.getBoundingClientRect();
    return [c.grasswidgetFramesDrawn || 0, r.bottom > 0 && r.top < innerHeight && r.right > 0 && r.left < innerWidth]; }"""


def _canvases(page):
    """Each view's canvas, scrolled into view. A view out of sight draws nothing (engine.js, views at rest) and
    draws once it is seen again: a canvas that was out of sight, or never drawn, is shot after that frame (on 2
    loaded cores the shot came first, and a never-drawn canvas was white in every try)."""
    import imageio.v3 as iio

    shots = []
    for k in range(page.locator("canvas.grasswidget-canvas").count()):
        loc = page.locator("canvas.grasswidget-canvas").nth(k)
        drawn, seen = loc.evaluate(_DRAWN_AND_SEEN)
        loc.scroll_into_view_if_needed()
        if not seen or drawn == 0:
            poll(lambda: loc.evaluate(_DRAWN_AND_SEEN)[0] > drawn, f"view {k} to draw once scrolled into view", 30, 0.1,
                 page=page)
        shots.append(iio.imread(loc.screenshot(), extension=".png")[..., :3].astype(int))
    return shots


def _run(page, server, root, name, cells, check, browser):
    write_notebook(root / name, cells)
    try:
        open_notebook(page, server, name)
        run_all_cells(page, timeout=120)
        check()
    except BaseException:
        from .chromium import save_debug_artifacts

        out = save_debug_artifacts(page, _artifacts(root), name, browser, server)
        print(f"\n[{name}] debug artifacts in {out}\n" + "\n".join(browser.console[-30:]))
        raise
    finally:
        try:
            leave_notebook(page, server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass


def _save_both_engines(page, out_dir):
    """From the same blades, parameters, steps and camera: the browser widget's save_png and
    the kernel engine's (a GrassScene on lavapipe) into ``out_dir``."""
    out = kernel_execute(page, f"""
from grasswidget.gpu.scene import GrassScene
w.pause()
w.params.wind_strength = 10.0
for name, value in {LOOKS!r}.items():  # the looks on, stronger than the defaults
    setattr(w.params, name, value)
w.reset_blades()
w.step(90)
cam = {{'position': {CAMERA['position']!r}, 'target': {CAMERA['target']!r}, 'fov_deg': {CAMERA['fov_deg']!r}}}
w.camera_state = cam
w.save_png({os.path.join(out_dir, 'engine_browser.png')!r}, size={SIZE})
import imageio.v3 as iio
iio.imwrite({os.path.join(out_dir, 'engine_browser_plain.png')!r}, w.view.engine_widget.snapshot({SIZE}))
scene = GrassScene(w.view.engine_widget.blades, size={SIZE}, params=w.params.copy())
scene.step(90)
scene.look(cam['position'], cam['target'], cam['fov_deg'])
scene.save_png({os.path.join(out_dir, 'engine_kernel.png')!r})
scene.release()
print('SAVED')
""", timeout=180)
    assert "SAVED" in out.stdout, out


#: The sunlight's comparison: shadows on, a low sun from the side and a ball in the field (hidden in
#: both engines: the ball's own translucent drawing differs, its shadow must not).
SUNLIGHT = {"shadows": True, "sun_elevation": 35.0, "sun_azimuth": -60.0}
BALL = ((1.5, 1.5, 4.0), 1.5)


def _save_both_engines_sunlit(page, out_dir):
    """As :func:`_save_both_engines`, with the sunlight on and a ball, into ``sunlit_*.png``."""
    out = kernel_execute(page, f"""
import grasswidget as gw
from grasswidget.gpu.scene import GrassScene
for name, value in {SUNLIGHT!r}.items():
    setattr(w.params, name, value)
ew = w.view.engine_widget
ew.show_colliders = False
ew.colliders = [gw.SphereCollider(center={BALL[0]!r}, radius={BALL[1]!r})]
w.reset_blades()
w.step(90)
w.save_png({os.path.join(out_dir, 'sunlit_browser.png')!r}, size={SIZE})
scene = GrassScene(ew.blades, size={SIZE}, params=w.params.copy())
scene.show_colliders = False
scene.colliders = [gw.SphereCollider(center={BALL[0]!r}, radius={BALL[1]!r})]
scene.step(90)
scene.look(cam['position'], cam['target'], cam['fov_deg'])
scene.save_png({os.path.join(out_dir, 'sunlit_kernel.png')!r})
# switched off again at run time: both engines drop the sunlight's shaders
w.params.shadows = False
scene.params.shadows = False
w.save_png({os.path.join(out_dir, 'sunlit_off_browser.png')!r}, size={SIZE})
scene.save_png({os.path.join(out_dir, 'sunlit_off_kernel.png')!r})
scene.release()
print('SAVED')
""", timeout=180)
    assert "SAVED" in out.stdout, out


def _compare_sunlit(out_dir):
    """The two engines draw the sunlight alike (the balls' and the grass' shadows, the roots), and it
    changes the picture (against the same view without it)."""
    import imageio.v3 as iio

    browser = iio.imread(os.path.join(out_dir, "sunlit_browser.png"))[..., :3].astype(int)
    kernel = iio.imread(os.path.join(out_dir, "sunlit_kernel.png"))[..., :3].astype(int)
    plain = iio.imread(os.path.join(out_dir, "engine_kernel.png"))[..., :3].astype(int)
    iio.imwrite(os.path.join(out_dir, "sunlit_side_by_side.png"),
                np.concatenate([kernel, np.full((SIZE[1], 4, 3), 255), browser], axis=1).astype(np.uint8))
    mean = float(np.abs(browser - kernel).mean())
    changed = float(np.abs(kernel - plain).mean())
    off_browser = iio.imread(os.path.join(out_dir, "sunlit_off_browser.png"))[..., :3].astype(int)
    off_kernel = iio.imread(os.path.join(out_dir, "sunlit_off_kernel.png"))[..., :3].astype(int)
    off_apart, off_changed = float(np.abs(off_browser - off_kernel).mean()), float(np.abs(off_browser - browser).mean())
    print(f"[engines alike, sunlight off again] mean |browser - kernel| = {off_apart:.2f}/255; the browser's picture "
          f"changed by {off_changed:.1f}/255 when switched off")
    assert off_apart < 2.5 and off_changed > 5.0
    print(f"[engines alike, sunlight] mean |browser - kernel| = {mean:.2f}/255; the sunlight changes the kernel's "
          f"picture by {changed:.1f}/255 on average; side by side: {os.path.join(out_dir, 'sunlit_side_by_side.png')}")
    assert changed > 5.0
    assert mean < 2.5


CAMERA = {"position": (5.0, 4.5, 15.0), "target": (0.0, 0.0, 0.0), "fov_deg": 50.0, "far": 100.0}
LOOKS = {"dryness": 0.3, "fog_density": 0.02, "patch_size": 2.5}


def _expected_ground(x_pixels):
    """The ground beyond the field (the far grass) in the bottom row at these columns, from the NumPy
    twins (sky_ground.wgsl's field_inside, ground_albedo, fog_amount) and engine_inputs's
    values: sRGB 0..255 per column, or None where the ray meets the field or its edge."""
    import grasswidget as gw
    from grasswidget.core import engine_inputs, reference as ref

    values = engine_inputs.sky_ground_values(gw.Blades.on_plane(N_BLADES), CAMERA["far"], gw.GrassParams(**LOOKS))
    pos, target = np.array(CAMERA["position"]), np.array(CAMERA["target"])
    forward = (target - pos) / np.linalg.norm(target - pos)
    right = np.cross(forward, (0.0, 1.0, 0.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan = np.tan(np.radians(CAMERA["fov_deg"]) / 2)
    out = []
    for x in x_pixels:
        ndc = (2 * (x + 0.5) / SIZE[0] - 1, -1 + 1 / SIZE[1])
        ray = forward + ndc[1] * tan * up + ndc[0] * tan * SIZE[0] / SIZE[1] * right
        hit = pos + (values["ground"][1] - pos[1]) / ray[1] * ray
        inside = ref.field_inside(hit[0], hit[2], np.array(values["field"][:2]), np.array(values["field"][2:]),
                                  values["field_edge"])
        if inside > 0:
            out.append(None)
            continue
        dist = np.linalg.norm(hit - pos)
        v = {k: np.asarray(values[k], np.float64) for k in ("soil_color", "beyond_color", "field", "far_grass",
                                                            "grass_root", "grass_tip")}
        ground = ref.ground_albedo(hit[0], hit[2], dist, v["soil_color"][:3], v["beyond_color"][:3], v["field"][:2],
                                   v["field"][2:], values["field_edge"], values["cover"], values["horizon"],
                                   values["far_blend"], v["far_grass"], v["grass_root"][:3], v["grass_tip"][:3],
                                   values["color_variation"], values["dryness"])
        fog = ref.fog_amount(dist, values["fog_density"])
        out.append(255 * (ground + (np.array(values["horizon_color"][:3]) - ground) * fog))
    return out


HORIZON_BLADES = 4096
HORIZON_SIZE, HORIZON_REACH = 6.0, 40.0  # near disc 3 m, blades out to 40 m (the camera's far plane: 100 m)


def _horizon_camera():
    """A camera 2.5 m up looking across the field to the horizon, inside its orbit limits."""
    import grasswidget as gw
    from grasswidget.core.orbit_limits import OrbitLimits, clamp_orbit

    b = gw.Blades.on_plane(HORIZON_BLADES, size=HORIZON_SIZE, reach=HORIZON_REACH, seed=2)
    limits = OrbitLimits.for_field(b.v0, b.up, b.height, 100.0, horizon=b.horizon)
    p, t = clamp_orbit((0.0, 2.5, 8.0), (0.0, 0.3, -3.0), limits)
    return {"position": tuple(map(float, p)), "target": tuple(map(float, t)), "fov_deg": 50.0}


def _save_both_engines_horizon(page, out_dir):
    """The field to the horizon in both engines: browser save_png and the kernel's, same blades, steps, camera."""
    cam = _horizon_camera()
    out = kernel_execute(page, f"""
import grasswidget as gw
from grasswidget.gpu.scene import GrassScene
w.pause()
w.view.engine_widget.colliders = []  # the sunlit pictures' ball: the kernel scene below has none
w.set_blades(gw.Blades.on_plane({HORIZON_BLADES}, size={HORIZON_SIZE}, reach={HORIZON_REACH}, seed=2))
w.reset_blades()
w.step(30)
cam = {cam!r}
w.camera_state = cam
w.save_png({os.path.join(out_dir, 'horizon_browser.png')!r}, size={SIZE})
scene = GrassScene(w.view.engine_widget.blades, size={SIZE}, params=w.params.copy())
scene.step(30)
scene.look(cam['position'], cam['target'], cam['fov_deg'])
scene.save_png({os.path.join(out_dir, 'horizon_kernel.png')!r})
scene.release()
print('SAVED')
""", timeout=180)
    assert "SAVED" in out.stdout, out


def _compare_engines_horizon(out_dir):
    import imageio.v3 as iio

    browser = iio.imread(os.path.join(out_dir, "horizon_browser.png"))[..., :3].astype(int)
    kernel = iio.imread(os.path.join(out_dir, "horizon_kernel.png"))[..., :3].astype(int)
    assert browser.shape == kernel.shape == (SIZE[1], SIZE[0], 3)
    iio.imwrite(os.path.join(out_dir, "engines_horizon_side_by_side.png"),
                np.concatenate([kernel, np.full((SIZE[1], 4, 3), 255), browser], axis=1).astype(np.uint8))
    mean = float(np.abs(browser - kernel).mean())
    # the band under the horizon: the rows below the sky down to a fifth of the picture
    sky = np.flatnonzero(((kernel[..., 2] > kernel[..., 1]) & (kernel[..., 2] > kernel[..., 0])).mean(1) > 0.9)
    top = int(sky.max()) + 2 if sky.size else SIZE[1] // 2
    band = slice(top, top + SIZE[1] // 5)
    shares = [float(((img[band, :, 1] > img[band, :, 0]) & (img[band, :, 1] > img[band, :, 2])).mean())
              for img in (kernel, browser)]
    print(f"[engines alike, to the horizon] mean |browser - kernel| = {mean:.2f}/255; the band under the horizon "
          f"(rows {band.start}..{band.stop}) is grass in {shares[0]:.1%} (kernel) and {shares[1]:.1%} (browser); "
          f"side by side: {os.path.join(out_dir, 'engines_horizon_side_by_side.png')}")
    assert min(shares) > 0.97
    assert mean < 2.0


def _compare_engines(out_dir):
    """The browser's save_png (anti-aliased in the browser) and the kernel's, with the
    looks on: nearly the same picture; the browser's plain snapshot is farther off."""
    import imageio.v3 as iio

    browser = iio.imread(os.path.join(out_dir, "engine_browser.png"))[..., :3].astype(int)
    plain = iio.imread(os.path.join(out_dir, "engine_browser_plain.png"))[..., :3].astype(int)
    kernel = iio.imread(os.path.join(out_dir, "engine_kernel.png"))[..., :3].astype(int)
    assert browser.shape == kernel.shape == plain.shape == (SIZE[1], SIZE[0], 3)
    iio.imwrite(os.path.join(out_dir, "engines_side_by_side.png"),
                np.concatenate([kernel, np.full((SIZE[1], 4, 3), 255), browser], axis=1).astype(np.uint8))
    diff = np.abs(browser - kernel)
    mean = float(diff.mean())
    plain_mean = float(np.abs(plain - kernel).mean())
    per_pixel = diff.max(axis=2)
    top = float(diff[: SIZE[1] // 10].mean())  # the top rows are sky in both (the gradient of one shader)
    print(f"[engines alike] mean |browser - kernel| = {mean:.2f}/255 over the picture (the browser's plain, "
          f"not anti-aliased snapshot: {plain_mean:.2f}/255), {top:.2f}/255 in the top rows (sky); "
          f"pixels differing by > 40: {(per_pixel > 40).mean():.2%}; "
          f"side by side: {os.path.join(out_dir, 'engines_side_by_side.png')}")
    # Both pictures show grass, sky and the ground beyond the field (to the horizon), so the
    # comparison compares pictures of all three.
    columns = [20, 60, 160, 260, 300]
    expected = _expected_ground(columns)
    assert sum(e is not None for e in expected) >= 3
    for img in (browser, kernel):
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        assert ((g > r + 8) & (g > b + 8)).mean() > 0.2  # grass
        assert ((b > r + 10) & (b >= g)).mean() > 0.05  # sky
        for x, want in zip(columns, expected):  # the ground beyond the field, fogged, as the twins say
            if want is not None:
                assert np.abs(img[-2:, x - 1: x + 2].mean(axis=(0, 1)) - want).max() < 3, (x, img[-1, x], want)
    assert top < 2.0
    assert mean < 2.0
    assert mean < 0.5 * plain_mean  # the browser's export is anti-aliased, as the kernel's


def test_one_simulation_per_widget_and_the_engines_draw_alike(webgpu_browser, lab_server, browser_root):
    """A widget displayed twice is one simulation; then the two engines' pictures of one state."""
    page = webgpu_browser.page
    out_dir = _artifacts(browser_root)

    def engines():
        return page.evaluate("() => [...(globalThis.__grasswidgetEngines || new Map()).values()]"
                             ".filter((e) => !e.closed).map((e) => ({views: e.views.size, steps: e.stepCount}))")

    def check():
        status = wait_for_kernel(page, "w.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=60)
        assert status["state"] == "ok", status
        poll(lambda: (page.locator("canvas.grasswidget-canvas").count() == 2, page.locator(
            "canvas.grasswidget-canvas").count()), "two canvases of the widget", 30, 0.3, page=page)
        # one engine with two views
        found = poll(lambda: (lambda e: (len(e) == 1 and e[0]["views"] == 2, e))(engines()),
                     "one engine with two views in the page", 30, 0.3, page=page)
        print(f"\n[displayed twice] engines in the page: {found}")
        # while playing, both views show the same meadow moving
        steps0 = kernel_eval(page, "w.stats.get('step_count') or 0")
        wait_for_kernel(page, "w.stats.get('step_count') or 0", predicate=lambda s: s > steps0 + 60, timeout=60)
        kernel_execute(page, "w.pause()")
        a0, b0 = poll(lambda: (lambda s: (bool(np.abs(s[0] - s[1]).max() == 0), s))(_canvases(page)),
                      "both views to show the same picture once paused", 30, 0.5, page=page)
        print(f"[displayed twice] paused: the two canvases are identical ({a0.shape[1]}x{a0.shape[0]})")
        # step and read_state: one simulation answers
        out = kernel_execute(page, """
s0 = w.view.engine_widget.read_state()['step_count']
w.step(37)
s1 = w.view.engine_widget.read_state()['step_count']
print('STEPS', s0, s1)
""", timeout=60)
        s0, s1 = map(int, out.stdout.split("STEPS")[1].split())
        assert s1 == s0 + 37
        assert [e["steps"] for e in engines()] == [s1]
        a1, b1 = poll(lambda: (lambda s: (bool(np.abs(s[0] - s[1]).max() == 0 and np.abs(s[0] - a0).max() > 40), s))(
            _canvases(page)), "both views to show the stepped meadow", 30, 0.5, page=page)
        moved = float((np.abs(a1 - a0).max(axis=2) > 40).mean())
        print(f"[displayed twice] step(37): {s0} -> {s1} steps, {moved:.1%} of the pixels changed, in both views")
        assert moved > 0.002
        _save_both_engines(page, out_dir)
        _save_both_engines_sunlit(page, out_dir)
        _save_both_engines_horizon(page, out_dir)

    _run(page, lab_server, browser_root, "displayed_twice.ipynb", [
        f"import grasswidget as gw\nw = gw.GrassWidget({N_BLADES}, backend='browser', size={SIZE})\nw",
        "w",
    ], check, webgpu_browser)
    _compare_engines(out_dir)
    _compare_sunlit(out_dir)
    _compare_engines_horizon(out_dir)


# ---------------------------------------------------------------------- occlusion culling ----------

OCCLUSION_SIZE = (320, 240)


def _occlusion_counts_and_pictures(page, out_dir):
    """The cis565 widget at rest, paused: the browser's stats with occlusion culling on, its
    picture on and off (save_png), and the kernel engine's counts for the same blades,
    parameters and camera at the browser's frame size."""
    # The compute rasterizer forced off: "auto" may try or choose it in the browser, and the
    # counts compared here are those of the ribbons' two occlusion phases.
    kernel_execute(page, "o.pause()\no.reset_blades()\no.params.compute_raster = False\no.params.cull_occlusion = True",
                   timeout=60)

    def settled():
        s = kernel_eval(page, "{k: o.stats.get(k) for k in ('visible', 'occluded', 'visible_per_class', 'frame_size', "
                              "'step_count')}")
        return s

    # Stats come every 0.5 s from the frames the browser draws; at rest with a still camera the
    # counts settle after two frames (the first frame draws every blade in its first phase).
    seen = []

    def steady():
        s = settled()
        seen.append(s)
        ok = (s["occluded"] is not None and s["step_count"] == 0 and len(seen) >= 3
              and all(x == s for x in seen[-3:]))
        return ok, s

    stats = poll(steady, "steady browser stats with occlusion culling on", 120, 1.0, page=page)
    w, h = stats["frame_size"]
    out = kernel_execute(page, f"""
import json
from grasswidget.gpu.scene import GrassScene
o.save_png({os.path.join(out_dir, 'occlusion_on.png')!r}, size={OCCLUSION_SIZE})
o.params.cull_occlusion = False
o.save_png({os.path.join(out_dir, 'occlusion_off.png')!r}, size={OCCLUSION_SIZE})
o.params.cull_occlusion = True
scene = GrassScene.preset('cis565', blades=o.view.engine_widget.blades, size=({w}, {h}), params=o.params.copy())
cam = o.camera_state
scene.look(cam['position'], cam['target'], cam['fov_deg'])
scene.render(); scene.render()
kernel = dict(drawn=int(scene.field.read_draw_args()[:, 1].sum()), occluded=int(scene.field.read_occluded_count()))
scene.params.cull_occlusion = False
scene.render()
kernel['drawn_without_occlusion'] = int(scene.field.read_draw_args()[:, 1].sum())
scene.release()
print('KERNEL' + json.dumps(kernel))
""", timeout=240)
    kernel = json.loads(out.stdout.split("KERNEL")[1].strip())
    return stats, kernel


def _check_occlusion(stats, kernel, out_dir):
    import imageio.v3 as iio

    on = iio.imread(os.path.join(out_dir, "occlusion_on.png"))[..., :3].astype(int)
    off = iio.imread(os.path.join(out_dir, "occlusion_off.png"))[..., :3].astype(int)
    assert on.shape == off.shape == (OCCLUSION_SIZE[1], OCCLUSION_SIZE[0], 3)
    iio.imwrite(os.path.join(out_dir, "occlusion_browser_on_off.png"),
                np.concatenate([on, np.full((on.shape[0], 4, 3), 255), off], axis=1).astype(np.uint8))
    diff = np.abs(on - off)
    differ = float((diff.max(axis=2) > 40).mean())
    drawn = stats["visible"]
    print(f"\n[occlusion, browser] cis565 at {stats['frame_size']}: drawn {drawn} + occluded {stats['occluded']} "
          f"= {drawn + stats['occluded']}; kernel: drawn {kernel['drawn']} + occluded {kernel['occluded']} = "
          f"{kernel['drawn'] + kernel['occluded']} (without occlusion {kernel['drawn_without_occlusion']}); "
          f"picture on vs off: mean |diff| {diff.mean():.3f}/255, {differ:.3%} of the pixels differ by > 40")
    # Near grass fills the cis565 view: most blades that pass the other tests are hidden.
    assert stats["occluded"] > 0.3 * (drawn + stats["occluded"])
    # Same blades, camera and frame size: the blades passing the orientation, frustum and
    # distance tests are the same in both engines (up to float rounding at the test edges) ...
    total_b, total_k = drawn + stats["occluded"], kernel["drawn"] + kernel["occluded"]
    assert total_k == kernel["drawn_without_occlusion"]
    assert abs(total_b - total_k) <= max(3, 0.002 * total_k)
    # ... and the occlusion test against each engine's own depth buffer hides about as many.
    assert abs(stats["occluded"] - kernel["occluded"]) <= 0.05 * kernel["occluded"] + 10
    # The picture is the picture without occlusion culling (rasterization noise only).
    assert diff.mean() < 0.5
    assert differ < 0.005
    green = (on[..., 1] > on[..., 0] + 8) & (on[..., 1] > on[..., 2] + 8)
    assert green.mean() > 0.3  # the near grass fills the view


def test_browser_occlusion_culling_draws_the_same_picture(webgpu_browser, lab_server, browser_root):
    """The browser engine with occlusion culling on: the picture without it, blades occluded in
    the cis565 view, and drawn + occluded as the kernel engine counts for the same camera."""
    page = webgpu_browser.page
    out_dir = _artifacts(browser_root)
    found = {}

    def check():
        status = wait_for_kernel(page, "o.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=60)
        assert status["state"] == "ok", status
        found["stats"], found["kernel"] = _occlusion_counts_and_pictures(page, out_dir)

    _run(page, lab_server, browser_root, "occlusion_browser.ipynb", [
        "import grasswidget as gw\n"
        f"o = gw.GrassWidget(preset='cis565', backend='browser', size={OCCLUSION_SIZE})\no",
    ], check, webgpu_browser)
    _check_occlusion(found["stats"], found["kernel"], out_dir)
