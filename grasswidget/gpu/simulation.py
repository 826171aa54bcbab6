"""The blade simulation of a GrassField: compute program, uniform writer, fixed steps.

:class:`Simulation` owns the simulation's uniform buffer, its compiled compute
program (``simulate.wgsl`` with the user's wind snippet) and the step counter.
``GrassField.step(n)`` delegates here: n fixed steps of ``params.dt`` in one
dispatch of one GPU submission, recorded into our own command encoder, never
inside ``renderer.render()``.
"""

from __future__ import annotations

from contextlib import nullcontext

import numpy as np
import pygfx as gfx
import wgpu
from pygfx.renderers.wgpu import Binding, get_shared
from pygfx.utils import array_from_shadertype

from ..core.collider_grid import GRID_WORDS, MAX_GRID_CELLS
from ..core.colliders import MAX_COLLIDERS, collider_array
from ..core.limits import StepsInterrupted, hold_interrupts
from ..core.engine_inputs import BLADE_STEPS_PER_DISPATCH, collider_grid, sim_uniform_values, steps_per_dispatch, wind_time
from ..core.shader_files import render_wgsl
from ..core.wgsl_overrides import parse_functions, wind_limit_error
from ..errors import ExerciseShaderError, IsolatedRunError, WindShaderError
from ..core.reference import wind_period
from ..core.shader_files import NO_WIND_BODY
from ..core.uniform_layouts import SIM_LAYOUT, shadertype, write_values
from .adapter import ensure_device
from .compute import ComputeProgram, destroy_buffers, sync_buffer
from .isolation import PROBE_ENTRY, check_compute, probe_entry, verdict_message
from .wgsl_templates import GrassComputeShader, naga_error_parts, overrides_error, workgroups

__all__ = ["Simulation", "SimulateShader", "SIM_UNIFORM", "wind_shader_error"]


#: ``u_sim`` as pygfx's shadertype (the layout: ``grasswidget.core.uniform_layouts.SIM_LAYOUT``).
SIM_UNIFORM = shadertype(SIM_LAYOUT)

_USER_WIND_SIGNATURE = "fn user_wind(p: vec3<f32>, t: f32) -> vec3<f32> {"


def wind_shader_error(err, wgsl, body):
    """Map a wgpu/naga error on the simulation shader to a WindShaderError with
    line numbers of the user's snippet (the body starts after the signature line)."""
    text = str(err)
    lines = wgsl.splitlines()
    start = next((k + 2 for k, line in enumerate(lines) if line.strip() == _USER_WIND_SIGNATURE), None)
    snippet_line, column, reason = naga_error_parts(text, start, len(body.splitlines()) or 1)
    if snippet_line is not None:
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
        self.step_count = 0
        self.wind_body = None
        self._program = None
        self._reverting_wind = False
        self._values = None  # the u_sim values but steps and time0 (uniform_values), and what they came from
        self._values_key = None

    # ------------------------------------------------------------------ program

    def build_program(self, body, blame=None):
        """Compile the simulation pipeline with ``body`` as user_wind; WindShaderError if it fails.

        User code (a ``body``, the field's function overrides) is checked first: the wind
        body's size limits (:func:`~grasswidget.core.wgsl_overrides.wind_limit_error`), then a
        compile of the whole shader in the isolated worker
        (:func:`~grasswidget.gpu.isolation.check_compute`); only a shader that compiled
        there is compiled here. A crash, a compile past the time or memory limit or a lost
        device there raises an error naming the cause: ExerciseShaderError when ``blame``
        is "overrides" (default: when there are overrides and no wind body), else
        WindShaderError."""
        overrides = self.field.function_overrides
        refused = wind_limit_error(body)
        if refused is not None:
            raise refused
        shader = SimulateShader(self.field, user_wind_body=body)
        if body.strip() or overrides is not None:
            shader.get_bindings_info(self.field, get_shared(), None)  # the bindings' code is part of the text
            wgsl = shader.generate_wgsl()
            checked, entries = wgsl, "main"
            if overrides is not None:  # every replaced function compiled, the culling ones too
                stock = {f.name: f for f in parse_functions(render_wgsl("blade_math.wgsl"))}
                checked += probe_entry([(n, [t for _, t in stock[n].params], stock[n].returns) for n in overrides.names
                                        if n in stock], wgsl)
                entries = ("main", PROBE_ENTRY)
            try:
                message = check_compute(checked, entries)
            except IsolatedRunError as err:
                if err.cause == "start":  # the worker, not the user's code
                    raise
                if blame == "overrides" or (blame is None and overrides is not None and not body.strip()):
                    raise ExerciseShaderError(verdict_message(err, overrides.label), None, None, err.verdict,
                                              err.detail) from None
                label = "wind_wgsl" if overrides is None else f"wind_wgsl or {overrides.label}"
                raise WindShaderError(verdict_message(err, label), None, None, err.verdict, err.detail) from None
            if message is not None:
                self._raise_compile_error(message, wgsl, body, overrides)
        try:
            return ComputeProgram(shader, self.field)
        except wgpu.GPUError as err:
            if overrides is None and not body.strip():
                raise  # the stock shader: not the user's error
            self._raise_compile_error(err, shader.generate_wgsl(), body, overrides)

    @staticmethod
    def _raise_compile_error(err, wgsl, body, overrides):
        if overrides is not None:
            error = overrides_error(err, wgsl, overrides)
            if error.line is not None or not body.strip():
                raise error from None
        raise wind_shader_error(err, wgsl, body) from None

    def compile_now(self, body, blame=None):
        """Compile ``body`` into the program now (no revert on error); ``blame``: see :meth:`build_program`."""
        self._program, self.wind_body = self.build_program(body, blame), body

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

    def uniform_values(self, steps=0, time0=0.0) -> dict:
        """The ``u_sim`` values for a dispatch of ``steps`` steps from ``time0`` s
        (:func:`grasswidget.core.engine_inputs.sim_uniform_values` of the params, colliders and world matrix).

        The values other than ``steps`` and ``time0`` are worked out again only when the params
        changed (:meth:`forget_uniform_values`, called by the field's params observer), the field
        moved or the number of colliders changed (about 0.2 ms of host work a step otherwise)."""
        field = self.field
        key = (field.world.last_modified, field.colliders.count, field.count)
        if self._values is None or key != self._values_key:
            self._values = sim_uniform_values(field.params, field.count, field.colliders,
                                              world_matrix=field.world.matrix)
            self._values_key = key
        return {**self._values, "steps": int(steps), "time0": float(time0)}

    def forget_uniform_values(self):
        """Work the ``u_sim`` values out again at the next dispatch (the params changed)."""
        self._values = None

    def write_uniform(self, steps, time0):
        """Fill ``u_sim`` from the params and colliders for a dispatch of ``steps`` steps from ``time0`` s."""
        d = self.uniform_buffer.data
        write_values(d, self.uniform_values(steps, time0))
        self.write_colliders()
        device = ensure_device()
        device.queue.write_buffer(sync_buffer(self.uniform_buffer), 0, d.tobytes())

    def write_colliders(self):
        """Upload the spheres and their grid (:func:`grasswidget.core.engine_inputs.collider_grid`) when
        the colliders changed since the last upload."""
        colliders = self.field.colliders
        key = (colliders.version if hasattr(colliders, "version") else collider_array(colliders).tobytes(),
               self.max_grid_cells)
        if key == self._grid_key and self.collider_grid is not None:
            return
        grid = collider_grid(colliders, self.field.blades, max_cells=self.max_grid_cells)
        device = ensure_device()
        device.queue.write_buffer(sync_buffer(self.colliders_buffer), 0, grid.sphere_data().tobytes())
        device.queue.write_buffer(sync_buffer(self.grid_buffer), 0, grid.words().tobytes())
        self.collider_grid, self._grid_key = grid, key

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
        per_dispatch = steps_per_dispatch(field.count)
        done = 0
        # Ctrl-C between two submissions stops after the one in flight, with step_count counting
        # exactly the steps submitted (StepsInterrupted); one submission is never cut.
        with hold_interrupts() if n > per_dispatch else nullcontext(None) as held:
            while done < n:
                chunk = min(per_dispatch, n - done)
                t0 = wind_time(self.step_count, field.params.dt, wind_period(field.params))
                self.write_uniform(chunk, t0)
                encoder = device.create_command_encoder()
                writes = field.stats.sim_timestamp_writes() if field.stats is not None else None
                cpass = encoder.begin_compute_pass(timestamp_writes=writes)
                self._program.dispatch(cpass, workgroups(field.count))
                cpass.end()
                device.queue.submit([encoder.finish()])
                self.step_count += chunk
                done += chunk
                if held is not None and held.hit:
                    break
        if held is not None and held.hit:
            raise StepsInterrupted(done, n)

    def release(self):
        """Free the uniform buffer and drop the program."""
        destroy_buffers([self.uniform_buffer, self.colliders_buffer, self.grid_buffer])
        self._program = None
