"""GrassField: a pygfx WorldObject holding a field of simulated grass blades.

It works in any pygfx scene: add it, render with any camera, and call
``field.step(n)`` to advance the physics by n fixed steps. Rendering never
advances time; it culls for the camera of that render and draws the survivors
with indirect draws (see :mod:`grasswidget.gpu.shaders`).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pygfx as gfx
import wgpu
from pygfx.utils import array_from_shadertype

from ..blades import Blades, pack_state, unpack_state
from ..colliders import MAX_COLLIDERS, ColliderList, collider_array
from ..memory import (BladeCountError, check_blade_count, check_gpu_blade_count, max_blades_for_gpu,
                      max_blades_for_memory)
from ..params import GrassParams
from ..reference import LOD_SEGMENTS, wind_period
from . import indirect
from .adapter import ensure_device
from .compute import ComputeProgram, destroy_buffers, sync_buffer
from .shaders import SimulateShader, register, workgroups

__all__ = ["GrassField", "GrassMaterial", "BladeLimitError", "WindShaderError", "check_blade_count_fits",
           "max_blade_count"]

BLADE_BYTES = 64
N_CLASSES = len(LOD_SEGMENTS)
#: Steps x blades of one dispatch; larger requests are split (keeps one dispatch short).
MAX_BLADE_STEPS_PER_DISPATCH = 1 << 30
SHAPES = ("quad", "triangle", "quadratic", "triangle-tip", "fold")

SIM_UNIFORM = dict(
    gravity_dir="4xf4",
    wind_dir="4xf4",
    gravity="f4",
    front_gravity="f4",
    stiffness_scale="f4",
    dt="f4",
    time0="f4",
    wind_strength="f4",
    wind_speed="f4",
    wind_wavelength="f4",
    wind_field="i4",
    steps="i4",
    n_blades="u4",
    gravity_center="4xf4",
    wind_center="4xf4",
    colliders=f"{MAX_COLLIDERS}*4xf4",
    gravity_mode="i4",
    wind_radius="f4",
    wind_direction_rad="f4",
    collision_fade="f4",
    collision_gain="f4",
    n_colliders="i4",
)
#: Wind field ids of simulate.wgsl's wind_field().
WIND_FIELD_IDS = {"wave": 0, "radial": 1, "vortex": 2, "noise": 3, "custom": 4}

CULL_UNIFORM = dict(
    orientation_threshold="f4",
    frustum_tolerance="f4",
    distance_max="f4",
    buckets="i4",
    cull_orientation="i4",
    cull_frustum="i4",
    cull_distance="i4",
    lod="i4",
    n_blades="u4",
)


class BladeLimitError(BladeCountError):
    """The blade count does not fit the device's storage-buffer limits (a ValueError
    naming ``count``, the limit and the memory it would take)."""


class WindShaderError(ValueError):
    """A ``wind_wgsl`` snippet (the body of ``user_wind``) does not compile.

    Attributes: ``line`` and ``column`` (1-based, within the snippet; None when
    the error is not inside it), ``reason`` (naga's one-line summary) and
    ``naga_message`` (the full message; its line numbers are those of the whole
    simulation shader). The previous wind stays in force.
    """

    def __init__(self, message, line=None, column=None, reason="", naga_message=""):
        super().__init__(message)
        self.line, self.column, self.reason, self.naga_message = line, column, reason, naga_message


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


class GrassMaterial(gfx.Material):
    """Colours, lighting and ribbon shape of grass blades.

    Uniforms (all documented as properties): ``root_color``, ``tip_color`` (sRGB),
    ``color_variation`` (0..1, per-blade brightness/hue spread), ``ambient``
    (0..1), ``light_direction`` (towards the light, world space),
    ``blade_shape`` (one of quad, triangle, quadratic, triangle-tip, fold) and
    ``tip_threshold`` (tau of the triangle-tip shape, 0..0.99).
    """

    uniform_type = dict(
        gfx.Material.uniform_type,
        root_color="4xf4",
        tip_color="4xf4",
        light_direction="4xf4",
        color_variation="f4",
        ambient="f4",
        tip_threshold="f4",
        blade_shape="i4",
    )

    def __init__(
        self,
        *,
        root_color="#1d4a12",
        tip_color="#8fc246",
        color_variation=0.35,
        ambient=0.4,
        light_direction=(0.4, 1.0, 0.3),
        blade_shape="triangle-tip",
        tip_threshold=0.5,
        **kwargs,
    ):
        super().__init__(**kwargs)
        self.root_color = root_color
        self.tip_color = tip_color
        self.color_variation = color_variation
        self.ambient = ambient
        self.light_direction = light_direction
        self.blade_shape = blade_shape
        self.tip_threshold = tip_threshold

    def _set(self, key, value):
        self.uniform_buffer.data[key] = value
        self.uniform_buffer.update_full()

    @property
    def root_color(self):
        """Colour at the blade root (sRGB)."""
        return gfx.Color(self.uniform_buffer.data["root_color"])

    @root_color.setter
    def root_color(self, color):
        self._set("root_color", gfx.Color(color))

    @property
    def tip_color(self):
        """Colour at the blade tip (sRGB)."""
        return gfx.Color(self.uniform_buffer.data["tip_color"])

    @tip_color.setter
    def tip_color(self, color):
        self._set("tip_color", gfx.Color(color))

    @property
    def color_variation(self):
        """Per-blade colour spread, 0 (none) .. 1."""
        return float(self.uniform_buffer.data["color_variation"])

    @color_variation.setter
    def color_variation(self, value):
        self._set("color_variation", _check_unit("color_variation", value))

    @property
    def ambient(self):
        """Ambient light share, 0..1."""
        return float(self.uniform_buffer.data["ambient"])

    @ambient.setter
    def ambient(self, value):
        self._set("ambient", _check_unit("ambient", value))

    @property
    def light_direction(self):
        """Unit direction towards the light (world space)."""
        return tuple(float(x) for x in self.uniform_buffer.data["light_direction"][:3])

    @light_direction.setter
    def light_direction(self, value):
        v = np.asarray(value, np.float64).reshape(3)
        norm = np.linalg.norm(v)
        if not np.all(np.isfinite(v)) or norm == 0:
            raise ValueError(f"light_direction must be a finite non-zero 3-vector; got {value!r}")
        self._set("light_direction", (*(v / norm), 0.0))

    @property
    def blade_shape(self):
        """Ribbon shape: one of quad, triangle, quadratic, triangle-tip, fold."""
        return SHAPES[int(self.uniform_buffer.data["blade_shape"])]

    @blade_shape.setter
    def blade_shape(self, value):
        if value not in SHAPES:
            raise ValueError(f"blade_shape must be one of {', '.join(SHAPES)}; got {value!r}")
        self._set("blade_shape", SHAPES.index(value))

    @property
    def tip_threshold(self):
        """tau of the triangle-tip shape: the blade narrows to its tip above v = tau (0..0.99)."""
        return float(self.uniform_buffer.data["tip_threshold"])

    @tip_threshold.setter
    def tip_threshold(self, value):
        v = float(value)
        if not (math.isfinite(v) and 0.0 <= v <= 0.99):
            raise ValueError(f"tip_threshold must be in [0, 0.99]; got {value!r}")
        self._set("tip_threshold", v)


def _check_unit(name, value):
    v = float(value)
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        raise ValueError(f"{name} must be in [0, 1]; got {value!r}")
    return v


def check_blade_limits(count, device):
    """Raise BladeLimitError when ``count`` blades do not fit one storage binding
    of ``device`` (see :func:`grasswidget.memory.check_gpu_blade_count`)."""
    check_gpu_blade_count(count, device.limits, device.adapter.summary, error=BladeLimitError)


def check_blade_count_fits(count, name=None) -> int:
    """Return ``count`` as an int when that many blades fit both the host memory
    (:func:`grasswidget.memory.check_blade_count`) and this device's buffers;
    else raise a :class:`~grasswidget.memory.BladeCountError` (a ValueError) naming
    ``count`` (and the caller's parameter ``name``), the limit and the memory. Allocates nothing: call it before making blades."""
    count = check_blade_count(count, name)
    device = ensure_device()
    return check_gpu_blade_count(count, device.limits, device.adapter.summary, name=name, error=BladeLimitError)


def max_blade_count() -> int:
    """The most blades that fit both the available host memory and this device's buffers."""
    gpu = max_blades_for_gpu(ensure_device().limits)
    host = max_blades_for_memory()
    return gpu if host is None else min(gpu, host)


class GrassField(gfx.WorldObject):
    """A field of grass blades simulated and drawn on the GPU.

    Args:
        blades: a :class:`grasswidget.Blades` (rest pose).
        params: a :class:`grasswidget.GrassParams` (default: a new one). Culling
            and LOD traits apply at the next render; physics at the next step.
        material: a :class:`GrassMaterial` (default: a new one).

    GPU memory per blade: 64 bytes of state + 4 bytes x LOD classes of
    compacted index lists + 4 bytes of collision strength (see :attr:`bytes_per_blade`).

    Physics extras: :attr:`colliders` (sphere colliders, read at every step),
    :meth:`set_wind_wgsl` (a WGSL wind, ``params.wind_field = "custom"``), and the
    params ``wind_field``, ``gravity_mode``/``gravity_direction``/``gravity_center``,
    ``collision_gain``/``collision_fade``; ``params.blade_shape`` drives
    ``material.blade_shape``.
    """

    def __init__(self, blades: Blades, params: GrassParams | None = None, material: GrassMaterial | None = None):
        if not isinstance(blades, Blades):
            raise TypeError(f"blades must be a grasswidget.Blades, not {type(blades).__name__}")
        if params is not None and not isinstance(params, GrassParams):
            raise TypeError(f"params must be a GrassParams, not {type(params).__name__}")
        device = ensure_device()
        check_blade_limits(len(blades), device)
        indirect.install()
        register(GrassField, GrassMaterial)

        lo = blades.v0.min(axis=0)
        hi = blades.v0.max(axis=0)
        reach = float(blades.height.max())
        corners = np.array([lo - reach, hi + reach], np.float32)
        super().__init__(gfx.Geometry(positions=corners), material or GrassMaterial())

        self.blades = blades
        self.params = params if params is not None else GrassParams()
        n = len(blades)
        usage = wgpu.BufferUsage
        self._store.blade_buffer = gfx.Buffer(
            blades.packed().reshape(n * 4, 4), usage=usage.STORAGE | usage.COPY_SRC | usage.COPY_DST
        )
        self._store.args_buffer = gfx.Buffer(
            nbytes=16 * N_CLASSES, nitems=4 * N_CLASSES, format="u4",
            usage=usage.INDIRECT | usage.STORAGE | usage.COPY_SRC | usage.COPY_DST,
        )
        self._store.visible_buffer = gfx.Buffer(
            nbytes=4 * N_CLASSES * n, nitems=N_CLASSES * n, format="u4", usage=usage.STORAGE | usage.COPY_SRC
        )
        self._sim_uniform = gfx.Buffer(array_from_shadertype(SIM_UNIFORM), force_contiguous=True)
        self._store.cull_uniform = gfx.Buffer(array_from_shadertype(CULL_UNIFORM), force_contiguous=True)
        self._step_count = 0
        self._sim_program = None
        # Per-blade collision strength eta (N float32), persistent across steps.
        self._store.collision_buffer = gfx.Buffer(
            np.zeros(n, np.float32), usage=usage.STORAGE | usage.COPY_SRC | usage.COPY_DST
        )
        self._colliders = ColliderList()
        self._sim_body = None  # wind_wgsl compiled into _sim_program
        self._reverting_wind = False
        if material is not None and self.material.blade_shape != self.params.blade_shape and self.params.blade_shape == "triangle-tip":
            self.params.blade_shape = self.material.blade_shape  # keep a material's explicit shape
        else:
            self.material.blade_shape = self.params.blade_shape
        if self.params.wind_wgsl.strip():
            self._sim_program, self._sim_body = self._build_sim_program(self.params.wind_wgsl), self.params.wind_wgsl
        #: Optional FrameStats (set by GrassScene or enable_stats()); None = no timing work.
        self.stats = None
        self._write_cull_uniform()
        self.params.observe(self._on_params_change)

    # ------------------------------------------------------------------ properties

    @property
    def count(self) -> int:
        """Number of blades N."""
        return len(self.blades)

    @property
    def blade_buffer(self):
        """pygfx Buffer, (4N, 4) float32: the blade state in the paper's 4 x vec4 layout."""
        return self._store.blade_buffer

    @property
    def args_buffer(self):
        """pygfx Buffer of LOD classes x (vertex_count, instance_count, 0, 0) u32 draw args."""
        return self._store.args_buffer

    @property
    def visible_buffer(self):
        """pygfx Buffer of LOD classes x N u32: compacted ids of the blades drawn per class."""
        return self._store.visible_buffer

    @property
    def _cull_uniform(self):
        return self._store.cull_uniform

    @property
    def collision_buffer(self):
        """pygfx Buffer, (N,) float32: per-blade collision strength eta (0..1)."""
        return self._store.collision_buffer

    @property
    def colliders(self) -> ColliderList:
        """Sphere colliders acting on this field (a list of :class:`SphereCollider`).

        Append, remove or move them (``ball.center = ...``) at any time; every
        ``step()`` reads the list and the spheres' current values. Coordinates are
        the field's local space (world space for an untransformed field). At most
        ``MAX_COLLIDERS`` (16): adding more raises ValueError naming ``colliders``;
        assigning any iterable (``field.colliders = [a, b]``) validates it the same way.
        """
        return self._colliders

    @colliders.setter
    def colliders(self, value):
        if value is self._colliders:
            return
        self._colliders = ColliderList(value)

    @property
    def step_count(self) -> int:
        """Fixed steps simulated since creation or the last reset()."""
        return self._step_count

    @property
    def bytes_per_blade(self) -> int:
        """GPU bytes per blade: state + compacted index lists + collision strength."""
        return BLADE_BYTES + 4 * N_CLASSES + 4

    # ------------------------------------------------------------------ params

    def _on_params_change(self, change):
        if change["name"].startswith("cull_") or change["name"] == "lod":
            self._write_cull_uniform()
        elif change["name"] == "blade_shape":
            self.material.blade_shape = change["new"]
        elif change["name"] == "wind_wgsl" and not self._reverting_wind:
            self._compile_wind(change["new"], change["old"])

    def _write_cull_uniform(self):
        p = self.params
        d = self._cull_uniform.data
        d["orientation_threshold"] = p.cull_orientation_threshold
        d["frustum_tolerance"] = p.cull_frustum_tolerance
        d["distance_max"] = p.cull_distance_max
        d["buckets"] = p.cull_buckets
        d["cull_orientation"] = int(p.cull_orientation)
        d["cull_frustum"] = int(p.cull_frustum)
        d["cull_distance"] = int(p.cull_distance)
        d["lod"] = int(p.lod)
        d["n_blades"] = self.count
        self._cull_uniform.update_full()

    # ------------------------------------------------------------------ simulation

    def _local_gravity_direction(self):
        """params.gravity_direction (world space) in the field's local space, unit length."""
        world = np.asarray(self.params.gravity_direction, np.float64)
        m = np.asarray(self.world.matrix, np.float64)[:3, :3]
        try:
            local = np.linalg.solve(m, world)
        except np.linalg.LinAlgError:
            local = world
        return local / max(np.linalg.norm(local), 1e-12)

    def _local_gravity_center(self):
        """params.gravity_center (world space) in the field's local space."""
        world = np.array([*self.params.gravity_center, 1.0])
        try:
            return np.linalg.solve(np.asarray(self.world.matrix, np.float64), world)[:3]
        except np.linalg.LinAlgError:
            return world[:3]

    # ------------------------------------------------------------------ user wind

    def _build_sim_program(self, body):
        """Compile the simulation pipeline with ``body`` as user_wind; WindShaderError if it fails."""
        shader = SimulateShader(self, user_wind_body=body)
        try:
            return ComputeProgram(shader, self)
        except wgpu.GPUError as err:
            if not body.strip():
                raise
            raise wind_shader_error(err, shader.generate_wgsl(), body) from None

    def _compile_wind(self, body, old):
        if body == self._sim_body:
            return
        try:
            program = self._build_sim_program(body)
        except WindShaderError:
            self._reverting_wind = True
            try:
                self.params.wind_wgsl = old
            finally:
                self._reverting_wind = False
            raise
        self._sim_program, self._sim_body = program, body

    def set_wind_wgsl(self, body: str, select: bool = True):
        """Use a WGSL snippet as the wind: the body of
        ``fn user_wind(p: vec3<f32>, t: f32) -> vec3<f32>`` (p: blade root in the
        field's local space, metres; t: time in seconds; returns W in m/s^2).

        Compiles now. On a compile error raises :class:`WindShaderError` whose
        ``line`` is the line within ``body``, and keeps the previous wind (and
        ``params.wind_wgsl``) in force. On success sets ``params.wind_wgsl`` and,
        with ``select``, ``params.wind_field = "custom"``. Same as assigning
        ``params.wind_wgsl`` (which compiles in every field using those params).
        The snippet may call any function of ``shaders/blade_math.wgsl`` (e.g.
        ``simplex_noise2(x, y)``, ``wind_wave(...)``) and read the simulation
        uniforms (e.g. ``u_sim.wind_strength``). Example::

            field.set_wind_wgsl("return vec3<f32>(8.0 * (1.0 + sin(t + 0.3 * p.x)), 0.0, 0.0);")
        """
        if not isinstance(body, str):
            raise TypeError(f"wind_wgsl must be a str (WGSL function body); got {type(body).__name__}")
        self.params.wind_wgsl = body
        if self._sim_body != body:  # params unchanged but never compiled here
            self._compile_wind(body, self.params.wind_wgsl)
        if select:
            self.params.wind_field = "custom"

    def _write_sim_uniform(self, steps, time0):
        p = self.params
        d = self._sim_uniform.data
        d["gravity_dir"] = (*self._local_gravity_direction(), 0.0)
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
        d["wind_field"] = WIND_FIELD_IDS[p.wind_field]
        d["steps"] = steps
        d["n_blades"] = self.count
        d["gravity_mode"] = 1 if p.gravity_mode == "point" else 0
        d["gravity_center"] = (*self._local_gravity_center(), 0.0)
        d["wind_center"] = (*p.wind_center, 0.0)
        d["wind_radius"] = p.wind_radius
        d["wind_direction_rad"] = rad
        d["collision_fade"] = p.collision_fade
        d["collision_gain"] = p.collision_gain
        spheres = collider_array(self._colliders)
        d["n_colliders"] = len(spheres)
        d["colliders"][:] = 0.0
        d["colliders"][: len(spheres)] = spheres
        device = ensure_device()
        device.queue.write_buffer(sync_buffer(self._sim_uniform), 0, d.tobytes())

    def step(self, n: int = 1):
        """Advance the physics by ``n`` fixed steps of ``params.dt`` (n >= 0).

        All n steps run in one dispatch of one GPU submission (the loop is in the
        shader; blades are independent). Step k uses wind time
        ``(k * dt) mod wind_period`` like the NumPy reference.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n (number of steps) must be an integer >= 0; got {n!r}")
        n = int(n)
        if n == 0:
            return
        device = ensure_device()
        collider_array(self._colliders)  # TypeError/ValueError before any work
        if self._sim_program is None:
            body = self.params.wind_wgsl
            self._sim_program, self._sim_body = self._build_sim_program(body), body
        sync_buffer(self.blade_buffer)
        sync_buffer(self.collision_buffer)
        per_dispatch = max(1, MAX_BLADE_STEPS_PER_DISPATCH // max(self.count, 1))
        done = 0
        while done < n:
            chunk = min(per_dispatch, n - done)
            period = wind_period(self.params)
            t0 = (self._step_count * self.params.dt)
            if period:
                t0 = math.fmod(t0, period)
            self._write_sim_uniform(chunk, t0)
            encoder = device.create_command_encoder()
            writes = self.stats.sim_timestamp_writes() if self.stats is not None else None
            cpass = encoder.begin_compute_pass(timestamp_writes=writes)
            self._sim_program.dispatch(cpass, workgroups(self.count))
            cpass.end()
            device.queue.submit([encoder.finish()])
            self._step_count += chunk
            done += chunk

    def release(self):
        """Free this field's GPU memory now; the field cannot be drawn or stepped afterwards."""
        try:  # the field observes its params: that reference would keep it alive
            self.params.unobserve(self._on_params_change)
        except ValueError:
            pass
        if self.stats is not None:
            self.stats.release()
            self.stats = None
        names = ("blade_buffer", "args_buffer", "visible_buffer", "cull_uniform", "collision_buffer")
        destroy_buffers([self._store[name] for name in names] + [self._sim_uniform])
        self._sim_program = None

    def enable_stats(self):
        """Create (once) and return this field's non-blocking FrameStats."""
        if self.stats is None:
            from .stats import FrameStats

            self.stats = FrameStats(self)
        return self.stats

    def reset(self):
        """Put every blade back in its rest pose, collision strengths and the step counter to 0."""
        self.blade_buffer.data[:] = self.blades.packed().reshape(-1, 4)
        self.blade_buffer.update_full()
        self.collision_buffer.data[:] = 0.0
        self.collision_buffer.update_full()
        self._step_count = 0

    # ------------------------------------------------------------------ readback

    def read_state(self) -> dict:
        """Copy the blade state from the GPU (synchronous).

        Returns a dict with "v0", "v1", "v2", "up" as (N, 3) float32 and "height",
        "width", "orientation", "stiffness", "collision" (eta, 0..1) as (N,) float32.
        """
        device = ensure_device()
        raw = device.queue.read_buffer(sync_buffer(self.blade_buffer))
        state = unpack_state(np.frombuffer(raw, np.float32).reshape(-1, 4, 4))
        raw = device.queue.read_buffer(sync_buffer(self.collision_buffer))
        state["collision"] = np.frombuffer(raw, np.float32).copy()
        return state

    def write_state(self, state: dict):
        """Upload a state dict (as returned by read_state) to the GPU (its "collision",
        if present, too)."""
        self.blade_buffer.data[:] = pack_state(state).reshape(-1, 4)
        self.blade_buffer.update_full()
        sync_buffer(self.blade_buffer)
        if "collision" in state:
            self.collision_buffer.data[:] = np.asarray(state["collision"], np.float32).reshape(-1)
            self.collision_buffer.update_full()
            sync_buffer(self.collision_buffer)

    def read_draw_args(self) -> np.ndarray:
        """(LOD classes, 4) u32 draw arguments of the last render (synchronous)."""
        device = ensure_device()
        raw = device.queue.read_buffer(sync_buffer(self.args_buffer))
        return np.frombuffer(raw, np.uint32).reshape(N_CLASSES, 4).copy()

    def read_visible(self) -> np.ndarray:
        """Sorted ids of the blades drawn by the last render (synchronous)."""
        device = ensure_device()
        args = self.read_draw_args()
        if self.visible_buffer._wgpu_object is None:
            return np.zeros(0, np.uint32)
        raw = device.queue.read_buffer(self.visible_buffer._wgpu_object)
        ids = np.frombuffer(raw, np.uint32).reshape(N_CLASSES, self.count)
        return np.sort(np.concatenate([ids[k, : args[k, 1]] for k in range(N_CLASSES)]))
