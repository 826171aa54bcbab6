"""The blade inspector: control points, control polygon and force arrows of up to
64 blades, drawn from the GPU state in every render (no readback).

``GrassField.inspect(ids)`` (and ``GrassScene.inspect``) shows it. A compute
shader (``inspect.wgsl``, registered for :class:`BladeInspector`) evaluates
the forces of the next step with blade_math.wgsl's functions, the twin of
:func:`grasswidget.core.reference.blade_forces`, and writes

* ``segments_buffer``: a pygfx Line of segments: per blade the polygon v0-v1,
  v1-v2, then one arrow (shaft + two head strokes) per force of
  ``reference.FORCE_NAMES`` (gravity, recovery, wind, collision) starting at v2,
  ``h / ARROW_ACCEL_PER_HEIGHT`` metres per m/s^2 (h: the blade's height), the
  collision push (m) ``COLLISION_ARROW_SCALE`` times longer;
* ``points_buffer``: v0, v1, v2 as pygfx Points;
* ``forces_buffer``: the raw vectors, for :meth:`BladeInspector.read`.

Unused slots and zero forces (no sphere touching: no collision arrow) are NaN,
which pygfx does not draw. Colours: :data:`grasswidget.core.teaching.INSPECTOR_COLORS`.
"""

from __future__ import annotations

import math

import numpy as np
import pygfx as gfx
import wgpu
from pygfx.renderers.wgpu import Binding, register_wgpu_render_function
from pygfx.utils import array_from_shadertype

from ..core.observers import WeakObserver
from ..core.reference import FORCE_NAMES, wind_period
from ..core.shader_files import NO_WIND_BODY
from ..core.teaching import (ARROW_ACCEL_PER_HEIGHT, COLLISION_ARROW_SCALE, INSPECTOR_COLORS, MAX_INSPECTED,
                             SEGMENT_VERTICES,
                             check_inspect_ids, inspected_rows, inspector_segment_colors)
from ..core.uniform_layouts import INSPECT_LAYOUT, shadertype
from .compute import sync_buffer
from .adapter import ensure_device
from .wgsl_templates import GrassComputeShader
from ..core.shader_files import wgsl_float

__all__ = ["BladeInspector", "BladeInspectorMaterial", "InspectShader", "SEGMENT_VERTICES"]

N_FORCES = len(FORCE_NAMES)

#: ``u_inspect`` as pygfx's shadertype (the layout: ``grasswidget.core.uniform_layouts.INSPECT_LAYOUT``).
INSPECT_UNIFORM = shadertype(INSPECT_LAYOUT)


class BladeInspectorMaterial(gfx.Material):
    """Material of the :class:`BladeInspector` (no settings; the drawing is done by
    its Line and Points children)."""


class BladeInspector(gfx.WorldObject):
    """Draws the blades of :attr:`ids` with their forces; a child of a GrassField.

    Attributes: ``field``, ``ids`` (tuple), ``lines`` (pygfx Line), ``points``
    (pygfx Points), ``segments_buffer``, ``points_buffer``, ``forces_buffer``.
    """

    def __init__(self, field):
        super().__init__(None, BladeInspectorMaterial())
        self.field = field
        usage = wgpu.BufferUsage
        n = MAX_INSPECTED
        self._store.inspect_uniform = gfx.Buffer(array_from_shadertype(INSPECT_UNIFORM), force_contiguous=True)
        nan = np.full((n * SEGMENT_VERTICES, 3), np.nan, np.float32)
        self._store.segments_buffer = gfx.Buffer(nan, usage=usage.STORAGE | usage.COPY_SRC)
        self._store.points_buffer = gfx.Buffer(np.full((3 * n, 3), np.nan, np.float32),
                                               usage=usage.STORAGE | usage.COPY_SRC)
        self._store.forces_buffer = gfx.Buffer(np.zeros((n * N_FORCES, 4), np.float32),
                                               usage=usage.STORAGE | usage.COPY_SRC)
        rgba = {k: gfx.Color(c).rgba for k, c in INSPECTOR_COLORS.items()}
        per_blade = [gfx.Color(c).rgba for c in inspector_segment_colors()]
        line_colors = np.tile(np.array(per_blade, np.float32), (n, 1))
        self.lines = gfx.Line(
            gfx.Geometry(positions=self.segments_buffer, colors=line_colors),
            gfx.LineSegmentMaterial(thickness=3.0, color_mode="vertex", depth_test=False),
        )
        point_colors = np.tile(np.array([rgba["points"]] * 3, np.float32), (n, 1))
        self.points = gfx.Points(
            gfx.Geometry(positions=self.points_buffer, colors=point_colors),
            gfx.PointsMaterial(size=9.0, color_mode="vertex", depth_test=False),
        )
        self.add(self.lines, self.points)
        self.render_order = 10  # over the grass
        self.ids = ()
        self.visible = False
        self._program = None  # compute_now's pipeline, and the WGSL it was built from
        self._program_key = None
        # The compute shader compiles the field's WGSL wind too (wind_field "custom").
        self._store.user_wind_body = field.params.wind_wgsl
        self._wind_observer = WeakObserver(field.params, self._on_wind_wgsl, names="wind_wgsl")

    @property
    def user_wind_body(self) -> str:
        """The field's ``wind_wgsl`` that the inspector's compute pass compiles (read
        from the pygfx store, so a change rebuilds the shader)."""
        return self._store.user_wind_body

    def _on_wind_wgsl(self, change):
        self._store.user_wind_body = change["new"]  # pygfx rebuilds the shader

    def release(self):
        """Stop following the field's params (the field is being released)."""
        self._program = None
        self._wind_observer.stop()

    segments_buffer = property(lambda self: self._store.segments_buffer,
                               doc="pygfx Buffer (64 x SEGMENT_VERTICES, 3) float32: the Line's vertices.")
    points_buffer = property(lambda self: self._store.points_buffer,
                             doc="pygfx Buffer (64 x 3, 3) float32: v0, v1, v2 of each slot.")
    forces_buffer = property(lambda self: self._store.forces_buffer,
                             doc="pygfx Buffer (64 x 4, 4) float32: the forces of each slot (m/s^2; xyz).")
    inspect_uniform = property(lambda self: self._store.inspect_uniform)

    def set_ids(self, ids):
        """Inspect these blades (validated: ValueError names the limit); [] hides the inspector."""
        ids = check_inspect_ids(ids, self.field.count)
        d = self.inspect_uniform.data
        d["ids"][:] = 0
        d["ids"].reshape(-1)[: len(ids)] = ids
        d["n_ids"] = len(ids)
        self.inspect_uniform.update_full()
        self.ids = tuple(int(i) for i in ids)
        self.visible = bool(self.ids)
        if self.ids:
            self.refresh_uniforms()

    def refresh_uniforms(self):
        """Write the field's simulation uniforms for "now": its parameters and
        colliders, at the time of the next step (no steps)."""
        field = self.field
        t = field.step_count * field.params.dt
        period = wind_period(field.params)
        if period:
            t = math.fmod(t, period)
        field.simulation.write_uniform(0, t)

    def _update_object(self):
        # pygfx calls this before every render: keep the parameters the forces use
        # current (a slider moved while paused, a ball moved between steps).
        super()._update_object()
        if self.ids:
            self.refresh_uniforms()

    def compute_now(self):
        """Run the inspector's compute pass now, outside a render (no drawing): the points and
        forces buffers then hold the inspected blades' numbers for the current state, as the
        next render would write them (the lab bench samples a ``step(n)`` this way when no frame
        is drawn). The pipeline is built once per WGSL (the field's wind and function overrides)
        and reused; nothing is waited for. No-op when nothing is inspected."""
        if not self.ids:
            return
        from .compute import ComputeProgram

        self.refresh_uniforms()
        overrides = self.field.function_overrides
        key = (self.user_wind_body, overrides.key if overrides is not None else "")  # what the WGSL depends on
        if self._program is None or self._program_key != key:
            self._program, self._program_key = ComputeProgram(InspectShader(self), self), key
        sync_buffer(self.inspect_uniform)  # new ids since the last dispatch or render
        device = ensure_device()
        encoder = device.create_command_encoder()
        cpass = encoder.begin_compute_pass()
        self._program.dispatch(cpass, (1, 1, 1))
        cpass.end()
        device.queue.submit([encoder.finish()])

    def read(self) -> list:
        """The inspected blades' numbers from the GPU (one small synchronous readback):
        a list of dicts with ``id``, ``height`` (m), ``stiffness`` (1/s^2, times
        ``params.stiffness_scale``), the points ``v0``, ``v1``, ``v2`` and one vector
        per name of ``reference.FORCE_NAMES`` (the field's local axes; gravity,
        recovery, wind in m/s^2, collision: the push of one step in m), as of the
        last render."""
        if not self.ids:
            return []
        device = ensure_device()
        n = len(self.ids)
        raw = device.queue.read_buffer(sync_buffer(self.forces_buffer), 0, n * N_FORCES * 16)
        forces = np.frombuffer(raw, np.float32).reshape(n, N_FORCES, 4)  # w: collision eta
        raw = device.queue.read_buffer(sync_buffer(self.points_buffer), 0, n * 3 * 12)
        points = np.frombuffer(raw, np.float32).reshape(n, 3, 3)
        blades = self.field.blades
        return inspected_rows(self.ids, blades.height, blades.stiffness, self.field.params.stiffness_scale,
                              points, forces)

    def read_segments(self) -> np.ndarray:
        """(64 x SEGMENT_VERTICES, 3) float32 vertices of the Line, as drawn (readback)."""
        device = ensure_device()
        raw = device.queue.read_buffer(sync_buffer(self.segments_buffer))
        return np.frombuffer(raw, np.float32).reshape(-1, 3).copy()


class InspectShader(GrassComputeShader):
    """The inspector's compute pass (one workgroup of 64), in every render."""

    def __init__(self, wobject):
        body = wobject.user_wind_body
        super().__init__(
            wobject,
            user_wind_body=body if body.strip() else NO_WIND_BODY,
            segment_vertices=SEGMENT_VERTICES,
            n_forces=N_FORCES,
            arrow_accel_per_height=wgsl_float(ARROW_ACCEL_PER_HEIGHT),
            collision_arrow_scale=wgsl_float(COLLISION_ARROW_SCALE),
        )

    def get_bindings(self, wobject, shared, scene):
        field = wobject.field
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer, "COMPUTE"),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer, "COMPUTE"),
            2: Binding("u_sim", "buffer/uniform", field.simulation.uniform_buffer, "COMPUTE"),
            3: Binding("u_inspect", "buffer/uniform", wobject.inspect_uniform, "COMPUTE"),
            10: Binding("s_blades", "buffer/read_only_storage", field.blade_buffer, "COMPUTE"),
            11: Binding("s_collision", "buffer/read_only_storage", field.collision_buffer, "COMPUTE"),
            12: Binding("s_segments", "buffer/storage", wobject.segments_buffer, "COMPUTE"),
            13: Binding("s_points", "buffer/storage", wobject.points_buffer, "COMPUTE"),
            14: Binding("s_forces", "buffer/storage", wobject.forces_buffer, "COMPUTE"),
            15: Binding("s_colliders", "buffer/read_only_storage", field.simulation.colliders_buffer, "COMPUTE"),
            16: Binding("s_collider_grid", "buffer/read_only_storage", field.simulation.grid_buffer, "COMPUTE"),
        }
        for slot in (0, 1, 2, 3, 10, 11, 14, 15, 16):
            self.define_binding(0, slot, bindings[slot])
        return {0: bindings}

    def get_code(self):
        # pygfx declares 3-float vertex buffers as vec3 arrays (16-byte stride):
        # the two Line/Points buffers are declared here as plain f32 arrays.
        return (
            "{{ bindings_code }}\n"
            "@group(0) @binding(12) var<storage, read_write> s_segments: array<f32>;\n"
            "@group(0) @binding(13) var<storage, read_write> s_points: array<f32>;\n"
            "{$ include 'grasswidget.inspect.wgsl' $}\n"
        )

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}


@register_wgpu_render_function(BladeInspector, BladeInspectorMaterial)
def inspector_render_function(wobject):
    """The inspector's passes: its compute shader (its children draw)."""
    return [InspectShader(wobject)]
