"""The blade simulation of a GrassField: compute program, uniform writer, fixed steps.

:class:`Simulation` owns the simulation's uniform buffer, its compiled compute
program (``simulate.wgsl`` with the user's wind snippet) and the step counter.
``GrassField.step(n)`` delegates here: n fixed steps of ``params.dt`` in one
dispatch of one GPU submission, recorded into our own command encoder, never
inside ``renderer.render()``.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pygfx as gfx
import wgpu
from pygfx.renderers.wgpu import Binding
from pygfx.utils import array_from_shadertype

from ..core.collider_grid import GRID_WORDS, MAX_GRID_CELLS, build_collider_grid, root_bounds
from ..core.colliders import MAX_COLLIDERS, collider_array
from ..core.enums import GravityMode, WindField
from ..errors import WindShaderError
from ..core.reference import wind_period
from ..core.shader_files import NO_WIND_BODY
from ..core.uniform_layouts import SIM_LAYOUT, shadertype
from .adapter import ensure_device
from .compute import ComputeProgram, destroy_buffers, sync_buffer
from .wgsl import GrassComputeShader, workgroups

__all__ = ["Simulation", "SimulateShader", "SIM_UNIFORM", "wind_shader_error"]

#: Steps x blades of one dispatch; larger requests are split (keeps one dispatch short).
MAX_BLADE_STEPS_PER_DISPATCH = 1 << 30

#: ``u_sim`` as pygfx's shadertype (the layout: ``grasswidget.core.uniform_layouts.SIM_LAYOUT``).
SIM_UNIFORM = shadertype(SIM_LAYOUT)

_USER_WIND_SIGNATURE = "fn user_wind(p: vec3<f32>, t: f32) -> vec3<f32> {"


def wind_shader_error(err, wgsl, body):
    """Map a wgpu/naga error on the simulation shader to a WindShaderError with
    line numbers of the user's snippet (the body starts after the signature line)."""
    text = str(err)
    lines = wgsl.splitlines()
    start = next((k + 2 for k, line in enumerate(lines) if line.strip() == _USER_WIND_SIGNATURE), None)
    n_body = len(body.splitlines()) or 1
    in_body = (lambda L: start is not None and start <= L < start + n_body)

    line = column = None
    head = re.search(r"┌─ [^:\n]*:(\d+):(\d+)", text)
    if head and in_body(int(head.group(1))):
        line, column = int(head.group(1)), int(head.group(2))
    else:
        gutter = text.splitlines()
        marked = []
        for k, row in enumerate(gutter):
            m = re.match(r"\s*(\d+) │", row)
            if m and in_body(int(m.group(1))):
                nxt = gutter[k + 1] if k + 1 < len(gutter) else ""
                marked.append((("^" not in nxt), int(m.group(1))))
        if marked:
            line = sorted(marked)[0][1]
    reasons = [r.strip() for r in re.findall(r"(?:error|Error): (.+)", text) if "Validation Error" not in r]
    notes = [r.strip()[2:] for r in text.splitlines() if r.strip().startswith("= ")]
    reason = "; ".join(dict.fromkeys(reasons + notes)) or text.strip().splitlines()[-1]
    if line is not None:
        snippet_line = line - start + 1
        src_line = body.splitlines()[snippet_line - 1] if snippet_line <= len(body.splitlines()) else ""
        col = f", column {column}" if column is not None else ""
        message = f"wind_wgsl line {snippet_line}{col}: {reason}\n  {snippet_line} | {src_line}"
        return WindShaderError(message, snippet_line, column, reason, text)
    message = f"wind_wgsl does not compile as the body of `{_USER_WIND_SIGNATURE} ... }}`: {reason}"
    return WindShaderError(message, None, None, reason, text)


class SimulateShader(GrassComputeShader):
    """Forces, state validation and collisions, ``u_sim.steps`` fixed steps per dispatch.

    ``user_wind_body`` is the body of ``fn user_wind(p, t) -> vec3<f32>`` (the
    "custom" wind field, ``params.wind_wgsl``); empty means no wind. Dispatched
    by :meth:`Simulation.step` (never by ``render()``). The pygfx bindings are
    generated here; ``simulate.wgsl`` is the engine-neutral body.
    """

    def __init__(self, wobject, user_wind_body=""):
        body = user_wind_body if user_wind_body.strip() else NO_WIND_BODY
        super().__init__(wobject, user_wind_body=body, blades_writable=True)

    def get_bindings(self, wobject, shared, scene):
        bindings = {
            0: Binding("u_sim", "buffer/uniform", wobject.simulation.uniform_buffer, "COMPUTE"),
            1: Binding("s_blades", "buffer/storage", wobject.blade_buffer, "COMPUTE"),
            2: Binding("s_collision", "buffer/storage", wobject.collision_buffer, "COMPUTE"),
            3: Binding("s_colliders", "buffer/read_only_storage", wobject.simulation.colliders_buffer, "COMPUTE"),
            4: Binding("s_collider_grid", "buffer/read_only_storage", wobject.simulation.grid_buffer, "COMPUTE"),
        }
        self.define_bindings(0, bindings)
        return {0: bindings}

    def get_code(self):
        return "{{ bindings_code }}\n{$ include 'grasswidget.simulate.wgsl' $}\n"

    def get_render_info(self, wobject, shared):
        return {"indices": workgroups(wobject.count)}


class Simulation:
    """The physics of one :class:`~grasswidget.gpu.field.GrassField`.

    Attributes: ``uniform_buffer`` (the ``u_sim`` uniforms, written before every
    dispatch), ``colliders_buffer`` (the spheres, MAX_COLLIDERS vec4) and ``grid_buffer``
    (the collider grid's u32 words, :mod:`grasswidget.core.collider_grid`; both written
    when the colliders changed since the last write, shared with the inspector),
    ``collider_grid`` (the last :class:`~grasswidget.core.collider_grid.ColliderGrid`
    uploaded), ``step_count`` (fixed steps since creation or the last reset; the
    wind time is ``step_count * dt``), ``wind_body`` (the ``wind_wgsl`` snippet
    compiled into the current program, or None before the first compile).
    """

    def __init__(self, field):
        self.field = field
        self.uniform_buffer = gfx.Buffer(
            array_from_shadertype(SIM_UNIFORM), force_contiguous=True, usage=wgpu.BufferUsage.UNIFORM
        )  # UNIFORM from the start: the inspector may write it before the first step
        storage = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST
        self.colliders_buffer = gfx.Buffer(np.zeros((MAX_COLLIDERS, 4), np.float32), usage=storage)
        self.grid_buffer = gfx.Buffer(np.zeros(GRID_WORDS, np.uint32), usage=storage)
        self.collider_grid = None
        #: Most cells of the collider grid (default MAX_GRID_CELLS); 1 makes every blade test
        #: every sphere (the paper's loop: for comparisons in tests and benchmarks).
        self.max_grid_cells = MAX_GRID_CELLS
        self._grid_key = None
        blades = field.blades
        self._bounds = root_bounds(blades.v0)
        self._max_height = float(np.max(blades.height)) if len(blades) else 0.0
        self.step_count = 0
        self.wind_body = None
        self._program = None
        self._reverting_wind = False

    # ------------------------------------------------------------------ program

    def build_program(self, body):
        """Compile the simulation pipeline with ``body`` as user_wind; WindShaderError if it fails."""
        shader = SimulateShader(self.field, user_wind_body=body)
        try:
            return ComputeProgram(shader, self.field)
        except wgpu.GPUError as err:
            if not body.strip():
                raise
            raise wind_shader_error(err, shader.generate_wgsl(), body) from None

    def compile_now(self, body):
        """Compile ``body`` into the program now (no revert on error)."""
        self._program, self.wind_body = self.build_program(body), body

    def compile_wind(self, body, old):
        """Compile a new wind snippet; on error put ``params.wind_wgsl`` back to ``old`` and raise."""
        if self._reverting_wind or body == self.wind_body:
            return
        try:
            program = self.build_program(body)
        except WindShaderError:
            self._reverting_wind = True
            try:
                self.field.params.wind_wgsl = old
            finally:
                self._reverting_wind = False
            raise
        self._program, self.wind_body = program, body

    # ------------------------------------------------------------------ uniforms

    def local_gravity_direction(self):
        """params.gravity_direction (world space) in the field's local space, unit length."""
        world = np.asarray(self.field.params.gravity_direction, np.float64)
        m = np.asarray(self.field.world.matrix, np.float64)[:3, :3]
        try:
            local = np.linalg.solve(m, world)
        except np.linalg.LinAlgError:
            local = world
        return local / max(np.linalg.norm(local), 1e-12)

    def local_gravity_center(self):
        """params.gravity_center (world space) in the field's local space."""
        world = np.array([*self.field.params.gravity_center, 1.0])
        try:
            return np.linalg.solve(np.asarray(self.field.world.matrix, np.float64), world)[:3]
        except np.linalg.LinAlgError:
            return world[:3]

    def write_uniform(self, steps, time0):
        """Fill ``u_sim`` from the params and colliders for a dispatch of ``steps`` steps from ``time0`` s."""
        field = self.field
        p = field.params
        d = self.uniform_buffer.data
        d["gravity_dir"] = (*self.local_gravity_direction(), 0.0)
        rad = math.radians(p.wind_direction)
        d["wind_dir"] = (math.cos(rad), math.sin(rad), 0.0, 0.0)
        d["gravity"] = p.gravity
        d["front_gravity"] = p.front_gravity
        d["stiffness_scale"] = p.stiffness_scale
        d["dt"] = p.dt
        d["time0"] = time0
        d["wind_strength"] = p.wind_strength
        d["wind_speed"] = p.wind_speed
        d["wind_wavelength"] = p.wind_wavelength
        d["wind_field"] = WindField.from_label(p.wind_field)
        d["steps"] = steps
        d["n_blades"] = field.count
        d["gravity_mode"] = GravityMode.from_label(p.gravity_mode)
        d["gravity_center"] = (*self.local_gravity_center(), 0.0)
        d["wind_center"] = (*p.wind_center, 0.0)
        d["wind_radius"] = p.wind_radius
        d["wind_direction_rad"] = rad
        d["collision_fade"] = p.collision_fade
        d["collision_gain"] = p.collision_gain
        spheres = self.write_colliders()
        d["n_colliders"] = len(spheres)
        device = ensure_device()
        device.queue.write_buffer(sync_buffer(self.uniform_buffer), 0, d.tobytes())

    def write_colliders(self):
        """Upload the spheres and their grid when the colliders changed since the last upload
        (a new grid from :func:`~grasswidget.core.collider_grid.build_collider_grid`); return
        the spheres (K, 4)."""
        colliders = self.field.colliders
        spheres = collider_array(colliders)
        key = (colliders.version if hasattr(colliders, "version") else spheres.tobytes(), self.max_grid_cells)
        if key == self._grid_key and self.collider_grid is not None:
            return spheres
        grid = build_collider_grid(spheres, self._bounds, self._max_height, max_cells=self.max_grid_cells)
        device = ensure_device()
        if len(spheres):
            device.queue.write_buffer(sync_buffer(self.colliders_buffer), 0, grid.spheres.tobytes())
        device.queue.write_buffer(sync_buffer(self.grid_buffer), 0, grid.words().tobytes())
        self.collider_grid, self._grid_key = grid, key
        return spheres

    # ------------------------------------------------------------------ time

    def step(self, n):
        """Advance by ``n`` (int >= 0, already validated) fixed steps; see GrassField.step."""
        if n == 0:
            return
        field = self.field
        device = ensure_device()
        collider_array(field.colliders)  # TypeError/ValueError before any work
        if self._program is None:
            self.compile_now(field.params.wind_wgsl)
        sync_buffer(field.blade_buffer)
        sync_buffer(field.collision_buffer)
        per_dispatch = max(1, MAX_BLADE_STEPS_PER_DISPATCH // max(field.count, 1))
        done = 0
        while done < n:
            chunk = min(per_dispatch, n - done)
            period = wind_period(field.params)
            t0 = (self.step_count * field.params.dt)
            if period:
                t0 = math.fmod(t0, period)
            self.write_uniform(chunk, t0)
            encoder = device.create_command_encoder()
            writes = field.stats.sim_timestamp_writes() if field.stats is not None else None
            cpass = encoder.begin_compute_pass(timestamp_writes=writes)
            self._program.dispatch(cpass, workgroups(field.count))
            cpass.end()
            device.queue.submit([encoder.finish()])
            self.step_count += chunk
            done += chunk

    def release(self):
        """Free the uniform buffer and drop the program."""
        destroy_buffers([self.uniform_buffer, self.colliders_buffer, self.grid_buffer])
        self._program = None
