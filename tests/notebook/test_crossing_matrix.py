"""The crossing matrix: every public measurement against every switch that changes what it measures.

Two tables, combined by parametrization: :data:`SWITCHES` (a switch, its values, how to set and
unset it on a live widget, and what it does to the picture) and :data:`MEASUREMENTS` (a public
number and its independent check). A new switch or a new measurement joins by one line; each
(switch, value, measurement) is one test.

One kernel-engine GrassWidget (2,048 blades, 160 x 120 px, wind off and settled) is re-configured
for each switch value and measured once: a frame, one ``step(1)`` and the frame after it, drawn
through jupyter-rfb's ``get_frame`` (the frames a page would get), then every readback of that
last frame, then its picture (an offscreen render of the same state and camera); the cells
assert on that record. The independent counts: the NumPy reference (``reference.cull``, ``reference.lod_class``) on
the state the GPU drew, for the camera that culls (the frozen one while frozen), minus what
occlusion removed as the GPU counted it. The browser engine's part runs without a browser: its view
gets the stats message its engine would send for the same frame (the same counter words, read with
``engine_inputs.read_counters`` as engine.js's twin does) and must show the same numbers.
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.notebook.panel import format_details
from conftest import grass_mask

# About 20 s in all on the 2-core lavapipe machine (most of it the first frames compiling pipelines).
pytestmark = pytest.mark.slow

BLADES, SIZE = 2048, (160, 120)
#: Steps after which the blades (no wind) are settled: a step more changes no pixel.
SETTLE_STEPS = 120
#: The camera of every cell (just above the grass, looking over it: near blades hide far ones, so
#: occlusion culling removes some, and far ones are thin enough for the compute rasterizer) and
#: the camera a frozen cull is seen from (above).
CAMERA = {"position": (0.0, 1.5, 14.0), "target": (0.0, 0.3, 0.0)}
ABOVE = {"position": (0.0, 16.0, 0.01), "target": (0.0, 0.0, 0.0)}
#: A class may differ from the reference's only for a blade whose projected height lies within
#: this relative distance of a class boundary (reference.LOD_MIN_PIXELS): the GPU computes the
#: height in float32 (a few ulp, ~1e-6 relative) from a matrix pygfx built in float32; the
#: reference in float64.
LOD_BOUNDARY_REL = 1e-4
#: Mean |difference| (0..255, over RGB) under which two pictures are "the same": occlusion culling
#: (conservative) and the compute rasterizer (sub-pixel coverage of the thin blades) measure 0.03 to
#: 0.05 here (the same state a step later), LOD off (8 segments for far blades instead of 1 or 2) 3.2.
SAME_PICTURE = 0.5
#: ... and above which a picture "changes" (the smallest change here: the ball, 2.6; run alone or in order).
CHANGED_PICTURE = 1.0


@dataclass
class Switch:
    """A switch: ``name``, its ``values`` (the first is the state every other switch is measured
    in), ``apply(widget, value)`` and ``picture``: "same" (the picture stays, up to ``same_within``,
    default :data:`SAME_PICTURE`) or "changes" (any value but the first changes it by more than
    :data:`CHANGED_PICTURE`)."""

    name: str
    values: tuple
    apply: object
    picture: str = "same"
    same_within: float = SAME_PICTURE


def _param(name):
    def apply(w, value):
        setattr(w.params, name, value)
    return apply


def _frozen(w, value):
    w.culling_frozen = False
    w.view.camera_state = dict(CAMERA)
    if value:
        w.view.draw()
        w.culling_frozen = True  # at CAMERA; then seen from above
        w.view.camera_state = dict(ABOVE)


def _camera(w, value):
    w.view.camera_state = dict(CAMERA if value == "in the grass" else ABOVE)


def _ball(w, value):
    w.ball.enabled = bool(value)
    if value:
        # At the patch's near edge (z = 5), where it touches about 50 blades and shows whole; deeper
        # in (z = 3.5) the grass in front hid most of it: the picture changed by 0.5 in the settled
        # state (1.4 with the blades fresh from set_blades).
        w.ball.collider.center = (0.0, w.ball.collider.radius, 4.5)


def _horizon(w, value):
    blades = gw.Blades.on_plane(BLADES, size=10.0, seed=5, reach=40.0 if value else None)
    if w.blade_count != len(blades) or bool(value) != (w.view.blades.horizon is not None):
        w.set_blades(blades)
        w.step(SETTLE_STEPS)  # the settled state kernel_widget starts from, for the switches after this one
    w.view.camera_state = dict(CAMERA)


#: The switches (every one that changes what is drawn or what is counted).
SWITCHES = [
    Switch("cull_occlusion", (False, True, "auto"), _param("cull_occlusion")),
    Switch("compute_raster", (False, True, "auto"), _param("compute_raster")),
    Switch("lod", (True, False), _param("lod"), same_within=4.0),
    Switch("camera", ("in the grass", "above"), _camera, picture="changes"),
    Switch("culling_frozen", (False, True), _frozen, picture="changes"),
    Switch("horizon", (False, True), _horizon, picture="changes"),
    Switch("ball", (False, True), _ball, picture="changes"),
    Switch("color_by", ("natural", "cull", "lod"), _param("color_by"), picture="changes"),
]


@dataclass
class Record:
    """What one frame measured (every public number, and the GPU's own readbacks)."""

    switch: Switch
    value: object
    picture: np.ndarray
    lod: bool
    kept: np.ndarray
    classes: np.ndarray
    pixels: np.ndarray
    stats: dict
    status: str
    details: str
    traces: dict
    state: dict
    rest: dict
    blades: int
    color_by: str
    rest_reason: np.ndarray
    visible_count: int
    drawn: dict
    ids: np.ndarray
    per_class: list
    rastered_ids: np.ndarray
    occluded: int
    occlusion_ran: bool


def _culling_camera(scene):
    frozen = scene.field.frozen_camera
    if frozen is not None:
        return frozen.view_proj, np.asarray(frozen.position, np.float64), frozen.viewport_size[1]
    cam = scene.camera
    view_proj = np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64)
    return view_proj, np.asarray(cam.world.position, np.float64), scene.renderer.physical_size[1]


def _frame(w):
    w.canvas.request_draw()
    w.canvas.get_frame()  # draws the frame a page would get (jupyter-rfb asks for it)


def _measure(w, switch, value) -> Record:
    _frame(w)  # a frame first: occlusion culling's first phase draws what the frame before saw
    w.step(1)
    _frame(w)
    w.view.refresh_stats()  # paused: the counts of that frame
    scene, f = w.view.scene, w.view.scene.field
    view_proj, cam_pos, height = _culling_camera(scene)
    state = f.read_state()
    p = w.params
    if w.view.blades.horizon is not None:
        # A field to the horizon thins itself with distance: distance culling is off for it
        # (core.engine_inputs.cull_uniform_values, "thinned"), whatever cull_distance says.
        p = p.copy()
        p.cull_distance = False
    kept = ref.cull(state, p, view_proj, cam_pos)
    rest = w.view.blades.rest_state()
    horizon = w.view.blades.horizon
    if horizon is not None:
        # ... and follows the camera: the culling pass moved each blade to its copy nearest the camera
        # (reference.follow_camera) and culls it where its level's weight is 0 (with distance)
        table = horizon.table()
        kept &= ref.blade_weights(state["v0"], cam_pos, table) > 0
        rest = dict(rest, v0=ref.follow_camera(rest["v0"], rest["v1"], rest["v2"], cam_pos, table)[0])
    rest_reason = ref.cull_reason(w.view.blades.rest_state(), p, view_proj, cam_pos)
    pixels = ref.projected_pixels(state["v0"], state["v2"], state["height"], view_proj, height)
    gpu = dict(visible_count=scene.visible_count(), drawn=scene.drawn_counts(), ids=f.read_visible(),
               per_class=f.read_visible(draw_order=True), rastered_ids=f.read_rastered(),
               occluded=f.read_occluded_count(), occlusion_ran=bool(f.frame_switches["cull_occlusion"]))
    # Last, once every count of the frame above is read: another frame of the same state and camera.
    picture = scene.render_at(antialias=False)
    return Record(
        switch, value, picture, bool(p.lod), kept, ref.lod_class(state["v0"], state["v2"], state["height"], view_proj, height),
        pixels, dict(w.stats), html.unescape(w.panel.stats_line.value), format_details(w.stats), w.traces(), state,
        rest, f.count, str(p.color_by), rest_reason, **gpu)


@pytest.fixture(scope="module")
def kernel_widget():
    w = gw.GrassWidget(blades=gw.Blades.on_plane(BLADES, size=10.0, seed=5), size=SIZE)
    w.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    w.params.wind_strength = 0.0
    w.params.cull_occlusion = False
    w.params.compute_raster = False
    w.view.camera_state = dict(CAMERA)
    w.step(SETTLE_STEPS)
    w.inspect([7, 311, 1500])
    yield w
    w.close()


@pytest.fixture(scope="module")
def records(kernel_widget):
    """{(switch name, value): Record}, measured lazily, each switch's values in order then
    back to its first value (so the next switch starts from the same state)."""
    cache = {}

    def get(switch, value):
        if switch.name not in {k[0] for k in cache}:
            for v in switch.values:
                switch.apply(kernel_widget, v)
                cache[(switch.name, repr(v))] = _measure(kernel_widget, switch, v)
            switch.apply(kernel_widget, switch.values[0])
        return cache[(switch.name, repr(value))]
    return get


@pytest.fixture(scope="module")
def browser_widget():
    w = gw.GrassWidget(blades=gw.Blades.on_plane(BLADES, size=10.0, seed=5), size=SIZE, backend="browser")
    yield w
    w.close()


# ------------------------------------------------------------------ the measurements and their checks

def check_counts(r: Record, _ctx):
    """visible_count() = drawn_counts() summed = the ids read back = the reference's kept blades
    less the ones occlusion removed (as the GPU counted them); every drawn blade is one the
    reference keeps."""
    assert r.visible_count == sum(r.drawn.values()) == len(r.ids)
    assert r.drawn["compute"] == len(r.rastered_ids)
    assert np.all(r.kept[r.ids]), f"{int(np.sum(~r.kept[r.ids]))} drawn blades the reference culls"
    occluded = r.occluded if r.occlusion_ran else 0
    assert r.visible_count == int(r.kept.sum()) - occluded, (r.visible_count, int(r.kept.sum()), occluded)
    assert r.visible_count > 0
    # each switch does what it is for here (else its cells would measure nothing new)
    if (r.switch.name, r.value) == ("cull_occlusion", True):
        assert r.occlusion_ran and r.occluded > 0.02 * r.visible_count, r.occluded
    if (r.switch.name, r.value) == ("compute_raster", True):
        assert r.drawn["compute"] > 0.05 * r.visible_count, r.drawn


def check_lod(r: Record, _ctx):
    """Each blade drawn as a ribbon is in the LOD class the reference gives it (class 0 with LOD
    off), except within LOD_BOUNDARY_REL of a class boundary; compute-drawn blades are in no class."""
    n = len(r.kept)
    gpu = np.full(n, -1)
    for k, ids in enumerate(r.per_class):
        gpu[np.asarray(ids, int)] = k
    ribbons = gpu >= 0
    assert int(ribbons.sum()) == r.drawn["hardware"]
    assert not np.any(ribbons[np.asarray(r.rastered_ids, int)])
    expected = r.classes if r.lod else np.zeros(n, int)
    differ = ribbons & (gpu != expected)
    bounds = np.asarray([b for b in ref.LOD_MIN_PIXELS if b > 0], np.float64)
    near = np.min(np.abs(r.pixels[:, None] / bounds[None, :] - 1.0), axis=1) < LOD_BOUNDARY_REL
    assert not np.any(differ & ~near), f"{int(np.sum(differ & ~near))} blades in another class, away from a boundary"


def check_stats(r: Record, _ctx):
    """w.stats: the frame's own counts (drawn, in compute, occluded only when occlusion ran)."""
    s = r.stats
    assert s["visible"] == r.visible_count and s["rastered"] == r.drawn["compute"] and s["blades"] == r.blades
    assert s["occluded"] == (r.occluded if r.occlusion_ran else None), (s["occluded"], r.occluded, r.occlusion_ran)


def check_status(r: Record, _ctx):
    """The status line and the panel's details say the same numbers as the stats."""
    assert f"{r.visible_count:,} of {r.blades:,} blades drawn" in r.status, r.status
    if r.drawn["compute"]:
        assert f"{r.drawn['hardware']:,} as ribbons, {r.drawn['compute']:,} in compute" in r.details, r.details
    assert (f"{r.occluded:,} occluded" in r.details) == r.occlusion_ran, r.details


def check_traces(r: Record, _ctx):
    """The lab bench's last sample is this frame's: its step, drawn by path, kept after occlusion
    (= drawn) and after distance (= drawn + occluded)."""
    t = r.traces
    assert t["step"][-1] == r.stats["step_count"]
    compute = t["drawn"]["compute"][-1]
    assert t["drawn"]["ribbons"][-1] == r.drawn["hardware"]
    assert (0 if math.isnan(compute) else compute) == r.drawn["compute"]
    assert t["kept"]["occlusion"][-1] == r.visible_count
    assert t["kept"]["distance"][-1] == r.visible_count + (r.occluded if r.occlusion_ran else 0)
    assert t["ids"].tolist() == [7, 311, 1500]
    # orientation and frustum: the reference on the rest pose for the culling camera (core.cull_counts)
    reason = r.rest_reason
    assert t["kept"]["orientation"][-1] == len(reason) - np.count_nonzero(reason == 1)
    assert t["kept"]["frustum"][-1] == np.count_nonzero((reason == 0) | (reason == 3))


def check_read_state(r: Record, _ctx):
    """read_state: finite, roots where the blades were planted (a field to the horizon: where the
    wrap's twin moves them for the culling camera), heights unchanged, and each blade's v2 above the
    ground."""
    for k in ("v0", "v1", "v2"):
        assert np.isfinite(r.state[k]).all()
    assert np.allclose(r.state["v0"], r.rest["v0"], atol=1e-5)
    assert np.allclose(r.state["height"], r.rest["height"])
    assert np.all(np.sum((r.state["v2"] - r.state["v0"]) * r.state["up"], axis=1) >= -1e-5)


def check_picture(r: Record, ctx):
    """The picture: grass where blades are drawn, and the same as the switch's first value's picture
    (switches that must not change it) or different from it (those that do)."""
    if r.color_by == "natural":
        grass = grass_mask(r.picture).mean()
        assert grass > 0.05, grass
    first = ctx["record"](r.switch, r.switch.values[0])
    diff = np.abs(r.picture[..., :3].astype(float) - first.picture[..., :3].astype(float)).mean()
    if r.switch.picture == "same" or r.value == r.switch.values[0]:
        assert diff < r.switch.same_within, diff
    else:
        assert diff > CHANGED_PICTURE, diff


def check_browser_engine(r: Record, ctx):
    """The browser engine's view, given the stats message its engine sends for this frame (the same
    counter words), shows the same numbers in its stats and its status line."""
    from grasswidget.core.engine_inputs import counter_layout, read_counters

    bw = ctx["browser"]()
    layout = counter_layout(len(r.per_class))
    words = np.zeros(layout["words"], np.uint32)
    for k, (i, _j) in enumerate(layout["visible"]):
        words[i] = len(r.per_class[k])  # both phases' draws: their sum is what counts
    words[layout["occluded"]] = r.occluded
    words[layout["rastered"]] = r.drawn["compute"]
    counts = read_counters(words, layout)
    bw.view.engine_widget.handle_message({
        "type": "stats", "fps": 30.0, "steps": 0, "visible": counts["visible_per_class"],
        "occluded": counts["occluded"] if r.occlusion_ran else None, "rastered": counts["rastered"],
        "step_count": int(r.stats["step_count"])})
    s = bw.stats
    assert s["visible"] == r.visible_count and s["rastered"] == r.drawn["compute"]
    assert s["occluded"] == r.stats["occluded"]
    assert f"{r.visible_count:,} of {bw.blade_count:,} blades drawn" in html.unescape(bw.panel.stats_line.value)


#: The measurements: name -> check(record, context). Each runs against every switch value.
MEASUREMENTS = {
    "counts": check_counts,
    "lod": check_lod,
    "stats": check_stats,
    "status": check_status,
    "traces": check_traces,
    "read_state": check_read_state,
    "picture": check_picture,
    "browser_engine": check_browser_engine,
}

CELLS = [pytest.param(s, v, m, id=f"{s.name}={v}-{m}") for s in SWITCHES for v in s.values for m in MEASUREMENTS]


@pytest.mark.parametrize("switch, value, measurement", CELLS)
def test_crossing(switch, value, measurement, records, request):
    ctx = {"record": records, "browser": lambda: request.getfixturevalue("browser_widget")}
    MEASUREMENTS[measurement](records(switch, value), ctx)


def test_traces_while_playing_count_their_own_frame(kernel_widget, records):
    """Playing, the camera moving every frame: each frame's sample in the traces has that frame's
    drawn counts (the GPU's, read synchronously after the frame here), though they reach the
    feed a frame or two later."""
    from conftest import TickingWall

    w = kernel_widget
    records(SWITCHES[0], SWITCHES[0].values[0])  # the matrix's record first (its own steps)
    w.view.clock.now = TickingWall(1.0 / w.max_fps)  # each frame drawn while playing: whole steps
    drawn_at_step = {}
    try:
        w.play()
        for k in range(8):
            x = -4.0 + 1.2 * k
            w.view.camera_state = {"position": (x, 1.5, 14.0), "target": (0.3 * x, 0.3, 0.0)}
            w.view.draw()
            drawn_at_step[int(w.view.scene.field.step_count)] = w.view.scene.visible_count()
    finally:
        w.pause()
        w.view.camera_state = dict(CAMERA)
    t = w.traces()
    got = {int(s): (r, c) for s, r, c in zip(t["step"], t["drawn"]["ribbons"], t["drawn"]["compute"])}
    assert len(set(drawn_at_step.values())) > 3  # the count changes from frame to frame
    for step, drawn in drawn_at_step.items():
        ribbons, compute = got[step]
        assert ribbons + (0 if math.isnan(compute) else compute) == drawn, (step, got[step], drawn)
        assert t["kept"]["occlusion"][list(t["step"]).index(step)] == drawn


def test_stats_while_playing_are_of_the_frame_their_step_count_names(kernel_widget, records):
    """Playing, the camera moving every frame: each stats refresh (at the end of a frame, twice a second
    in a live view) gives that frame's counts beside its step count, as the status line shows them
    and as the frame's trace sample has them (before, the counts were of a frame or two earlier)."""
    from conftest import TickingWall

    w = kernel_widget
    records(SWITCHES[0], SWITCHES[0].values[0])
    w.view.clock.now = TickingWall(1.0 / w.max_fps)
    seen = []
    try:
        w.play()
        for k in range(6):
            x = -4.0 + 1.5 * k
            w.view.camera_state = {"position": (x, 1.5, 14.0), "target": (0.3 * x, 0.3, 0.0)}
            w.view.draw()
            w.view.refresh_stats()
            s = w.stats
            drawn = w.view.scene.visible_count()  # synchronous: this frame's
            seen.append(drawn)
            assert s["step_count"] == w.view.scene.field.step_count
            assert s["visible"] == drawn, (k, s["visible"], drawn)
            assert f"{drawn:,} of {BLADES:,} blades drawn" in html.unescape(w.panel.stats_line.value)
    finally:
        w.pause()
        w.view.camera_state = dict(CAMERA)
    assert len(set(seen)) > 3  # the count changes from frame to frame
    t = w.traces()
    for step, ribbons, compute in zip(t["step"][-6:], t["drawn"]["ribbons"][-6:], t["drawn"]["compute"][-6:]):
        assert ribbons + (0 if math.isnan(compute) else compute) in seen, (step, ribbons, compute)
