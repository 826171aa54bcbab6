"""The kernel engine's frame entry point: :func:`render_frame` draws one frame of a scene.

``GrassScene.render``, the widget's kernel view and the exports all draw through it. It is a
plain ``renderer.render(scene, camera)`` unless a visible GrassField has occlusion culling on;
then the frame runs in the phases of :mod:`grasswidget.gpu.occlusion` (the first phase inside
``render()``, the depth pyramid, the second culling phase and its draws outside it in one
submission, then the translucent ``late`` objects): one ``render()`` call, two with late
objects. Every visible GrassField is first set up for the renderer's size
(``GrassField.prepare_compute_raster``), and every visible SkyGround's cache decides whether
its sky and ground are shaded or copied this frame (``SkyGroundCache.prepare``: copied while
the camera, the size and their values stay what the last frame had).
"""

from __future__ import annotations

import pygfx as gfx

from ..errors import GrassValueError
from .trial_timing import begin_frame
from .occlusion import OcclusionCulling
from .sky_ground import SkyGround

__all__ = ["render_frame"]


def _fields(scene):
    out = []
    scene.traverse(lambda ob: out.append(ob) if isinstance(getattr(ob, "occlusion", None), OcclusionCulling) else None,
                   skip_invisible=True)
    return out


def _draws_something(ob) -> bool:
    """True when ``ob`` or a visible descendant has a material (e.g. not GrassScene's
    collider-ball group while there are no colliders): a late render of nothing is skipped."""
    return any(o.material is not None for o in ob.iter(skip_invisible=True))


def _prepare_sunlight(skies, fields):
    """Each visible GrassField's sunlight into its material; the first one's into every visible
    sky and ground ``skies`` (its balls' and grass' shadows on the ground)."""
    values = [field.prepare_sunlight() for field in fields]
    if not values:
        return
    for ob in skies:
        ob.material.set_sunlight(values[0])


def _sky_grounds(scene):
    grounds = []
    scene.traverse(lambda ob: grounds.append(ob) if isinstance(ob, SkyGround) else None, skip_invisible=True)
    return grounds


def render_frame(renderer, scene, camera, late=()):
    """Render ``scene`` with ``camera`` like ``renderer.render(scene, camera)``, with
    occlusion culling for every visible GrassField of the scene whose
    ``params.cull_occlusion`` is on: True, or "auto" and the field's measured decision on
    (:mod:`grasswidget.gpu.trial_timing`; :mod:`grasswidget.gpu.occlusion` describes the phases).

    ``late``: direct children of ``scene`` drawn after the second phase (translucent
    objects that write no depth, e.g. collider balls), with the scene's lights. With
    no armed field this is one plain ``renderer.render(scene, camera)``.

    Every visible GrassField is first set up for the renderer's size
    (``GrassField.prepare_compute_raster``: the compute rasterizer of thin blades
    when ``params.compute_raster`` is on) and gets its sunlight (``GrassField.prepare_sunlight``:
    the sun, ``params.shadows``, the balls), which every visible SkyGround takes from the first.
    """
    all_fields = _fields(scene)
    switches = begin_frame(all_fields, camera)  # "auto" switches decided by measuring (core.auto_switches)
    for field in all_fields:  # what this frame runs: its counts are read with it (gpu.stats)
        field.frame_switches = dict(switches.values[field])
    try:
        _render_frame(renderer, scene, camera, late, all_fields, switches)
    finally:
        switches.end()


def _render_frame(renderer, scene, camera, late, all_fields, switches):
    for field in all_fields:
        field.prepare_compute_raster(renderer.physical_size, on=switches.value(field, "compute_raster"))
    skies = _sky_grounds(scene)
    _prepare_sunlight(skies, all_fields)
    for sky in skies:  # a still view's sky and ground: copied, not shaded again
        sky.cache.prepare(renderer, camera)
    fields = [f for f in all_fields if switches.value(f, "cull_occlusion")]
    # Occlusion off this frame by a measured choice that may turn it on again: the second
    # phase's draws are prepared with the frame's render and their draw calls dropped (nothing
    # drawn), so that pygfx keeps their pipelines; left out for a few frames it drops them and
    # builds them again at the next "on" (a CPU adapter JIT-compiles each build: 7 MB a trial).
    resting = [f for f in all_fields if f not in fields and f.params.cull_occlusion == "auto"]
    if not fields:
        for field in resting:
            field.occlusion.draws.defer_draws()
        try:
            renderer.render(scene, camera)
        finally:
            for field in resting:
                field.occlusion.draws.stop_deferring()
                field.occlusion.draws.take_deferred()  # prepared, never drawn
        return
    capturing = [f for f in fields if f.occlusion.capture_camera is not None]
    for field in capturing:
        field.occlusion.capture(renderer, scene)
    late = [ob for ob in late if ob.visible]
    for ob in late:
        if ob.parent is not scene:
            raise GrassValueError("render_frame: the late objects must be direct children of the scene")
    late = [ob for ob in late if _draws_something(ob)]
    try:
        for ob in late:
            ob.visible = False
        for field in fields:
            field.occlusion.arm(1)
            field.occlusion.draws.defer_draws()  # prepared by this render, drawn by second_phase
        renderer.render(scene, camera, clear=True, flush=False)
    finally:
        for ob in late:
            ob.visible = True
        for field in fields:
            field.occlusion.arm(0)
            field.occlusion.draws.stop_deferring()
    for field in fields:
        field.occlusion.second_phase(renderer)
    if late:
        hidden = [ob for ob in scene.children if ob not in late and not isinstance(ob, gfx.Light) and ob.visible]
        try:
            for ob in hidden:
                ob.visible = False
            renderer.render(scene, camera, clear=False, flush=False)
        finally:
            for ob in hidden:
                ob.visible = True
    renderer.flush()
