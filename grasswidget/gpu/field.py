"""GrassField: a pygfx WorldObject holding a field of simulated grass blades.

It works in any pygfx scene: add it, render with any camera, and call
``field.step(n)`` to advance the physics by n fixed steps. Rendering never
advances time; it culls for the camera of that render and draws the survivors
with indirect draws (see :mod:`grasswidget.gpu.shader_classes`).
"""

from __future__ import annotations


import numpy as np
import pygfx as gfx
import wgpu
from pygfx.utils import array_from_shadertype

from .. import compat
from ..core.blades import BLADE_BYTES, Blades, pack_state, unpack_state
from ..core.colliders import ColliderList
from ..core.limits import check_steps, nonfinite_cause, nonfinite_message, warn_nonfinite
from ..errors import BladeLimitError, GrassTypeError, GrassValueError, WindShaderError, refuse_when_closed
from ..core.memory import check_blade_count, check_gpu_blade_count, max_blades_for_gpu, max_blades_for_memory
from ..core.observers import WeakObserver
from ..core.params import LOOK_TRAITS, GrassParams
from ..core.reference import LOD_SEGMENTS
from ..core.engine_inputs import MAX_RASTER_BLADES, compute_raster_on, cull_uniform_values, look_values  # noqa: F401 (MAX_RASTER_BLADES: kept here too)
from ..core.engine_inputs import grass_layer, sunlight_values
from ..core.uniform_layouts import CULL_LAYOUT, shadertype, write_values
from . import indirect
from .adapter import ensure_device
from .compute import destroy_buffers, sync_buffer
from .draw_bundles import DrawBundle
from ..core.teaching import FrozenView
from .frozen_camera import FrozenCamera, frustum_line
from .raster_walks import raster_packed
from .material import GrassMaterial
from .occlusion import OcclusionCulling
from .simulation import Simulation
from .wgsl_templates import WORKGROUP_SIZE, workgroups

__all__ = ["GrassField", "GrassMaterial", "BladeLimitError", "WindShaderError", "check_blade_count_fits",
           "max_blade_count"]

# Distance bands per LOD class (the draw order of the culled lists): one source for both
# engines, in grasswidget.core.shader_files.
from ..core.shader_files import BAND_RANGE, DISTANCE_BANDS, RASTER_DISPATCH_WORDS  # noqa: E402,F401


N_CLASSES = len(LOD_SEGMENTS)


#: ``u_cull`` as pygfx's shadertype (the layout: ``grasswidget.core.uniform_layouts.CULL_LAYOUT``).
CULL_UNIFORM = shadertype(CULL_LAYOUT)



def check_blade_limits(count, device):
    """Raise BladeLimitError when ``count`` blades do not fit one storage binding
    of ``device`` (see :func:`grasswidget.core.memory.check_gpu_blade_count`)."""
    check_gpu_blade_count(count, device.limits, device.adapter.summary, error=BladeLimitError)


def check_blade_count_fits(count, name=None) -> int:
    """Return ``count`` as an int when that many blades fit both the host memory
    (:func:`grasswidget.core.memory.check_blade_count`) and this device's buffers;
    else raise a :class:`~grasswidget.errors.BladeCountError` (a ValueError) naming
    ``count`` (and the caller's parameter ``name``), the limit and the memory.
    Allocates nothing: call it before making blades."""
    count = check_blade_count(count, name)
    device = ensure_device()
    return check_gpu_blade_count(count, device.limits, device.adapter.summary, name=name, error=BladeLimitError)


def max_blade_count() -> int:
    """The most blades that fit both the available host memory and this device's buffers."""
    gpu = max_blades_for_gpu(ensure_device().limits)
    host = max_blades_for_memory()
    return gpu if host is None else min(gpu, host)


@refuse_when_closed("GrassField")
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
            raise GrassTypeError(f"blades must be a grasswidget.Blades, not {type(blades).__name__}")
        if params is not None and not isinstance(params, GrassParams):
            raise GrassTypeError(f"params must be a GrassParams, not {type(params).__name__}")
        device = ensure_device()
        check_blade_limits(len(blades), device)
        indirect.install()

        lo = blades.v0.min(axis=0)
        hi = blades.v0.max(axis=0)
        reach = float(blades.height.max())
        if blades.horizon is not None:  # the blades follow the camera anywhere within the reach
            reach += float(blades.horizon.reach)
        corners = np.array([lo - reach, hi + reach], np.float32)
        super().__init__(gfx.Geometry(positions=corners), material or GrassMaterial())

        self._released = False
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
        # Culling's distance-band counters and cursors (see cull.wgsl).
        self._store.band_buffer = gfx.Buffer(
            nbytes=8 * N_CLASSES * DISTANCE_BANDS, nitems=2 * N_CLASSES * DISTANCE_BANDS, format="u4",
            usage=usage.STORAGE,
        )
        # u_cull is bound as read-only storage, not as a uniform (see gpu/wgsl_templates.py: lavapipe's leak).
        self._store.cull_uniform = gfx.Buffer(array_from_shadertype(CULL_UNIFORM), force_contiguous=True,
                                              usage=usage.STORAGE)
        # The draw of the culled blades (color_by "cull"): args, and the list of
        # id | reason << 30, allocated (N u32) the first time "cull" is used.
        self._store.culled_args_buffer = gfx.Buffer(
            nbytes=16, nitems=4, format="u4", usage=usage.INDIRECT | usage.STORAGE | usage.COPY_SRC
        )
        self._store.culled_buffer = gfx.Buffer(nbytes=4, nitems=1, format="u4", usage=usage.STORAGE)
        # Occlusion culling: one bit per blade "seen last frame" (whole workgroups of
        # words), and the second phase's draw args + occluded count (see cull.wgsl).
        # All seen at first: the first frame draws everything the other tests keep in
        # its first phase, and culling frozen before any frame hides nothing.
        words = workgroups(n)[0] * workgroups(n)[1] * (WORKGROUP_SIZE // 32)
        self._store.occlusion_flags_buffer = gfx.Buffer(
            np.full(words, 0xFFFFFFFF, np.uint32), usage=usage.STORAGE | usage.COPY_SRC | usage.COPY_DST
        )
        self._store.occlusion_args_buffer = gfx.Buffer(
            nbytes=16 * (N_CLASSES + 1), nitems=4 * (N_CLASSES + 1), format="u4",
            usage=usage.INDIRECT | usage.STORAGE | usage.COPY_SRC,
        )
        self._store.flat_colors = self.params.color_by != "natural"
        # User WGSL in place of stock blade-math functions (set_function_overrides; tracked by
        # pygfx: a change builds the culling pipelines again).
        self._store.function_overrides = None
        # The compute rasterizer of thin blades (raster.wgsl): its list and counters
        # (listed, first occlusion phase's part, the rows written: first, ~last), and
        # per-pixel depth and payload words, allocated by prepare_compute_raster (one item
        # each until then). Its layout (raster_walks.py): one walk of packed u64 words
        # where the device has 64-bit atomics (the payload buffer then stays one item).
        self._store.raster_packed = raster_packed(device)
        one = dict(nbytes=4, nitems=1, format="u4", usage=usage.STORAGE)
        self._store.raster_list_buffer = gfx.Buffer(**one)
        self._store.raster_args_buffer = gfx.Buffer(np.zeros(4, np.uint32), usage=usage.STORAGE | usage.COPY_SRC)
        self._store.raster_depth_buffer = gfx.Buffer(**(dict(one, nbytes=8, nitems=2) if self.raster_packed else one))
        self._store.raster_payload_buffer = gfx.Buffer(**one)
        # The shaded colours of the pixels the walks won (raster.wgsl's step "shade"): two words per pixel.
        self._store.raster_color_buffer = gfx.Buffer(**dict(one, nbytes=8, nitems=2))
        # The walks' workgroups (x, y, z, 0), written by raster.wgsl's args step, the clear's,
        # written by its clear_args step, and the shade's, written by its shade_args step.
        self._store.raster_dispatch_buffer = gfx.Buffer(np.zeros(RASTER_DISPATCH_WORDS, np.uint32),
                                                        usage=usage.STORAGE | usage.INDIRECT)
        self._store.raster_size = (0, 0)
        # Raster buffers replaced by a size change, destroyed at the next prepare: the frame
        # that replaced them may already hold encoded, unsubmitted passes that use them.
        self._store.raster_retired = []
        self._frozen_camera = None
        #: The frozen culling camera's view volume (a pygfx Line child); None until frozen.
        self.frustum_lines = None
        #: The blade inspector (a child :class:`~grasswidget.gpu.inspector.BladeInspector`),
        #: created by the first :meth:`inspect`.
        self.inspector = None
        #: The physics: compute program, ``u_sim`` uniform writer and step counter.
        self.simulation = Simulation(self)
        # Per-blade collision strength eta (N float32), persistent across steps, then one word:
        # the flag simulate.wgsl sets when it put a non-finite blade back at rest (note_reset_flag).
        self._store.collision_buffer = gfx.Buffer(
            np.zeros(n + 1, np.float32), usage=usage.STORAGE | usage.COPY_SRC | usage.COPY_DST
        )
        #: How many readbacks found blades put back at rest by the finite check (check_finite).
        self.nonfinite_resets = 0
        self._warned_cause = None
        self._colliders = ColliderList()
        # What the sunlight needs of the blades (their rectangle, leaf area, height: O(N), once).
        self._grass_layer = grass_layer(blades)
        self._sunlight_written = None
        if material is not None and self.material.blade_shape != self.params.blade_shape and self.params.blade_shape == "triangle-tip":
            self.params.blade_shape = self.material.blade_shape  # keep a material's explicit shape
        else:
            self.material.blade_shape = self.params.blade_shape
        for name, value in look_values(self.params).items():  # the params drive the material's looks
            setattr(self.material, name, value)
        if self.params.wind_wgsl.strip():
            self.simulation.compile_now(self.params.wind_wgsl)
        #: Optional FrameStats (set by GrassScene or enable_stats()); None = no timing work.
        self.stats = None
        #: What the "auto" switches were in the last frame drawn through
        #: :func:`grasswidget.gpu.render_frame`: {"cull_occlusion": bool, "compute_raster": bool}
        #: (the decision of an "auto" value); None before the first such frame.
        self.frame_switches = None
        #: The blade draws (one per LOD class and the culled blades), replayed from a render
        #: bundle (:mod:`grasswidget.gpu.draw_bundles`).
        self.blade_draw_bundle = DrawBundle(N_CLASSES + 1)
        #: Occlusion culling's pyramid, second phase and draws (see :mod:`grasswidget.gpu.occlusion`).
        self.occlusion = OcclusionCulling(self)
        self._write_cull_uniform()
        # Weakly: shared params must not keep a field nobody holds (core.observers).
        self._params_observer = WeakObserver(self.params, self._on_params_change)

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
    def band_buffer(self):
        """pygfx Buffer of the culling's per (LOD class, distance band) counters and cursors (u32)."""
        return self._store.band_buffer

    @property
    def culled_args_buffer(self):
        """pygfx Buffer of (vertex_count, instance_count, 0, 0) u32: the draw of the
        culled blades (instances only with ``params.color_by == "cull"``)."""
        return self._store.culled_args_buffer

    @property
    def occlusion_flags_buffer(self):
        """pygfx Buffer of u32: bit i of word i // 32 is 1 when blade i passed every
        culling test, occlusion included, in the last frame with occlusion culling."""
        return self._store.occlusion_flags_buffer

    @property
    def occlusion_args_buffer(self):
        """pygfx Buffer of u32: the second occlusion phase's (vertex_count,
        instance_count, 0, 0) per LOD class, then (occluded blades, 0, 0, 0)."""
        return self._store.occlusion_args_buffer

    @property
    def flat_colors(self) -> bool:
        """True while ``params.color_by`` is "lod" or "cull" (flat teaching colours).
        The ribbon shaders carry the flat-colour path only then: on a GPU it costs
        about 40 % of the blade draws (one more interpolated vec4 per vertex), so
        switching colour modes rebuilds the ribbon pipelines instead."""
        return self._store.flat_colors

    @property
    def culled_buffer(self):
        """pygfx Buffer of u32: ids of culled blades | reason << 30 (color_by "cull")."""
        return self._store.culled_buffer

    @property
    def cull_uniform_buffer(self):
        """pygfx Buffer of the ``u_cull`` uniforms (culling switches and thresholds, from params)."""
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
        ``MAX_COLLIDERS`` (1024), counting the rows of ``colliders.set_array(a)`` (a (K, 4)
        array of centres and radii: the cheap way to move a crowd every frame): adding
        more raises ValueError naming ``colliders``; assigning any iterable
        (``field.colliders = [a, b]``) validates it the same way. The spheres and their
        grid (:mod:`grasswidget.core.collider_grid`) are uploaded at the next step when
        they changed; each blade tests only the spheres near it.
        """
        return self._colliders

    @colliders.setter
    def colliders(self, value):
        if value is self._colliders:
            return
        self._colliders = ColliderList(value)

    @property
    def step_count(self) -> int:
        """Fixed steps simulated since creation or the last reset() (the wind time is
        ``step_count * params.dt``). Settable (an int >= 0), e.g. to restore a saved state."""
        return self.simulation.step_count

    @step_count.setter
    def step_count(self, value):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise GrassValueError(f"step_count must be an integer >= 0; got {value!r}")
        self.simulation.step_count = int(value)

    @property
    def bytes_per_blade(self) -> int:
        """GPU bytes per blade: state + compacted index lists + collision strength."""
        return BLADE_BYTES + 4 * N_CLASSES + 4

    # ------------------------------------------------------------------ params

    def _on_params_change(self, change):
        self.simulation.forget_uniform_values()
        if change["name"].startswith("cull_") or change["name"] in ("lod", "color_by", "compute_raster_max_px"):
            self._write_cull_uniform()
            self._store.flat_colors = self.params.color_by != "natural"
        elif change["name"] == "blade_shape":
            self.material.blade_shape = change["new"]
        elif change["name"] in LOOK_TRAITS:  # the values the browser engine is sent too
            setattr(self.material, change["name"], look_values(self.params)[change["name"]])
        elif change["name"] == "wind_wgsl":
            self.simulation.compile_wind(change["new"], change["old"])
            self._warned_cause = None  # a new snippet that fails is worth its own warning

    def _write_cull_uniform(self):
        """``u_cull`` from the params and the frozen camera (values: engine_inputs.cull_uniform_values)."""
        p = self.params
        if p.color_by == "cull" and self.culled_buffer.nitems < self.count:
            self._store.culled_buffer = gfx.Buffer(
                nbytes=4 * self.count, nitems=self.count, format="u4", usage=wgpu.BufferUsage.STORAGE
            )
        write_values(self.cull_uniform_buffer.data, cull_uniform_values(p, self.count, self._frozen_camera,
                                                                         horizon=self.blades.horizon))
        self.cull_uniform_buffer.update_full()

    # ------------------------------------------------------------------ compute rasterizer

    @property
    def raster_list_buffer(self):
        """pygfx Buffer of u32: ids of the blades the compute rasterizer draws (raster.wgsl)."""
        return self._store.raster_list_buffer

    @property
    def raster_args_buffer(self):
        """pygfx Buffer of 4 u32: blades listed for the compute rasterizer, where the first
        occlusion phase's part ends, the first pixel row the walks wrote and the bitwise
        complement of the last (raster.wgsl; first > last: none)."""
        return self._store.raster_args_buffer

    @property
    def raster_dispatch_buffer(self):
        """pygfx Buffer of 12 u32 (``RASTER_DISPATCH_WORDS``): the compute rasterizer's walks'
        workgroups (x, y, z, 0), written on the GPU after the culling (raster.wgsl, step "args"),
        then its clear's (x, y, z, 0) for the rows the last frame wrote (step "clear_args", before
        the culling), then its shade's for the rows this frame's walks wrote (step "shade_args",
        after them); the walks, the clear and the shade are dispatched indirectly from it."""
        return self._store.raster_dispatch_buffer

    @property
    def raster_color_buffer(self):
        """pygfx Buffer of two u32 per pixel: the colour (sRGB, f16 pairs (r, g), (b, 0)) raster.wgsl's
        step "shade" gave each pixel a compute-rasterized blade won; the resolve writes it."""
        return self._store.raster_color_buffer

    @property
    def raster_depth_buffer(self):
        """pygfx Buffer of the compute rasterizer's depth words (float bits): a u32 per pixel, or
        with :attr:`raster_packed` a u64 per pixel (depth and payload; :meth:`read_raster_pixels`)."""
        return self._store.raster_depth_buffer

    @property
    def raster_payload_buffer(self):
        """pygfx Buffer of u32 per pixel: the compute rasterizer's payload (blade << 8 | v); one
        unused item with :attr:`raster_packed` (the payload is in :attr:`raster_depth_buffer`)."""
        return self._store.raster_payload_buffer

    @property
    def raster_packed(self) -> bool:
        """True when this field's compute rasterizer walks once with 64-bit atomics: a u64 per
        pixel in :attr:`raster_depth_buffer` (u32 words 2 i + 1: depth bits, 2 i: the
        complement of the payload) and :attr:`raster_payload_buffer` unused; False: two walks,
        a u32 per pixel in each (as the browser engine). Fixed when the field is created
        (:mod:`grasswidget.gpu.raster_walks`)."""
        return self._store.raster_packed

    def read_raster_pixels(self):
        """The compute rasterizer's words of the last render, whatever the layout
        (synchronous): (depth, payload), each a (height, width) uint32 array; depth is the
        float bits of the pixel's depth (``reference.RASTER_EMPTY`` where no blade was
        written), payload ``blade << 8 | round(v * 255)`` (0 where empty). None while off."""
        width, height = self.raster_size
        if not width:
            return None
        device = ensure_device()
        words = np.frombuffer(device.queue.read_buffer(sync_buffer(self.raster_depth_buffer)), np.uint32)
        if self.raster_packed:
            pairs = words[: 2 * width * height].reshape(height, width, 2)
            depth = pairs[..., 1].copy()
            payload = np.where(depth == 0xFFFFFFFF, np.uint32(0), ~pairs[..., 0]).astype(np.uint32)
            return depth, payload
        payload = np.frombuffer(device.queue.read_buffer(sync_buffer(self.raster_payload_buffer)), np.uint32)
        return words[: width * height].reshape(height, width).copy(), payload[: width * height].reshape(height, width).copy()

    @property
    def raster_size(self) -> tuple:
        """(width, height) pixels of the renders the compute rasterizer runs in; (0, 0) while off."""
        return self._store.raster_size

    @property
    def compute_raster_active(self) -> bool:
        """True while the compute rasterizer draws this field's thin blades (see
        :meth:`prepare_compute_raster`)."""
        return self._store.raster_size != (0, 0)

    def prepare_compute_raster(self, size, on=None):
        """Set up the compute rasterizer for renders of ``size`` = (width, height) physical
        pixels (``renderer.physical_size``), or switch it off when ``params.compute_raster``
        is off (or ``compute_raster_max_px`` is 0). :func:`grasswidget.gpu.render_frame`
        calls it before every frame; a plain ``renderer.render()`` of another size draws
        every blade with the hardware rasterizer. Fields of more than 2^24 blades draw
        every blade with the hardware rasterizer (the payload holds 24 bits of blade id).
        ``on``: the view's decision for ``compute_raster`` "auto" (None: off).
        """
        p = self.params
        if self._store.raster_retired:  # the frame that replaced them has been submitted since
            destroy_buffers(self._store.raster_retired)
            self._store.raster_retired = []
        width, height = (int(size[0]), int(size[1])) if compute_raster_on(p, self.count, on) else (0, 0)
        if width <= 0 or height <= 0:
            width = height = 0
        usage = wgpu.BufferUsage
        if width and self.raster_list_buffer.nitems < self.count:
            self._store.raster_list_buffer = gfx.Buffer(nbytes=4 * self.count, nitems=self.count, format="u4",
                                                        usage=usage.STORAGE | usage.COPY_SRC)
        if (width, height) != self._store.raster_size:
            pixels = max(width * height, 1)
            old = [self._store.raster_depth_buffer, self._store.raster_payload_buffer, self._store.raster_color_buffer]
            # Counters all zero: the rows written read "every row", so the first clear of the
            # new pixel words (raster.wgsl, which clears only the rows the last frame wrote)
            # clears them whole. Zeroed in place: the culling passes keep the buffer bound
            # (a replaced one stayed bound there and was destroyed under them).
            args = self._store.raster_args_buffer
            args.data[:] = 0
            args.update_full()
            words = 2 * pixels if self.raster_packed else pixels  # packed: a u64 per pixel
            self._store.raster_depth_buffer = gfx.Buffer(nbytes=4 * words, nitems=words, format="u4",
                                                         usage=usage.STORAGE | usage.COPY_SRC)
            payload = 1 if self.raster_packed else pixels
            self._store.raster_payload_buffer = gfx.Buffer(nbytes=4 * payload, nitems=payload, format="u4",
                                                           usage=usage.STORAGE | usage.COPY_SRC)
            self._store.raster_color_buffer = gfx.Buffer(nbytes=8 * pixels, nitems=2 * pixels, format="u4",
                                                         usage=usage.STORAGE)
            self._store.raster_size = (width, height)
            self._store.raster_retired = old
        data = self.cull_uniform_buffer.data
        shape = int(self.material.uniform_buffer.data["blade_shape"])
        tau = float(self.material.uniform_buffer.data["tip_threshold"])
        values = dict(compute_raster=int(width > 0), raster_width=float(width), raster_height=float(height),
                      raster_blade_shape=shape, raster_tip_threshold=tau)
        if any(data[k] != v for k, v in values.items()):
            write_values(data, values)
            self.cull_uniform_buffer.update_full()

    def sunlight_values(self) -> dict:
        """The sunlight's values of this field's material now (``core.engine_inputs.sunlight_values``
        of the params, the blades and the colliders): what :meth:`prepare_sunlight` writes, and
        what a sky and ground drawn with the field take (``SkyGroundMaterial.set_values``)."""
        return sunlight_values(self.params, self._grass_layer, self._colliders)

    def prepare_sunlight(self) -> dict:
        """Write the sunlight (``params.shadows``, the sun's direction, the balls' shadows: the
        first ``reference.MAX_SHADOW_BALLS`` colliders) into the material when it changed, and
        return it (:meth:`sunlight_values`). :func:`grasswidget.gpu.render_frame` calls it before
        every frame. The params' sun is the material's ``light_direction`` from then on."""
        values = self.sunlight_values()
        key = tuple(np.asarray(v, np.float64).tobytes() for v in values.values())
        if key != self._sunlight_written:
            self.material.set_sunlight(values)
            self._sunlight_written = key
        return values

    def read_raster_count(self) -> int:
        """Blades the compute rasterizer drew in the last render (both occlusion phases; synchronous)."""
        raw = ensure_device().queue.read_buffer(sync_buffer(self.raster_args_buffer))
        return int(np.frombuffer(raw, np.uint32)[0])

    # ------------------------------------------------------------------ frozen culling

    def freeze_culling(self, camera, viewport_size=None):
        """Cull and pick LOD classes against a copy of ``camera`` from now on.

        Copies the camera's world pose and projection at the aspect of
        ``viewport_size`` ((width, height) in physical pixels of the view it
        renders; also the pixel scale of the LOD classes). Any camera may then
        render the field: the same blades stay culled, and the copy's view volume
        is drawn as white lines (:attr:`frustum_lines`, a child of the field).
        Freezing again replaces the copy. Occlusion culling freezes too: the next
        :func:`~grasswidget.gpu.frame.render_frame` first renders the frozen view
        once (same target) to find the blades it hides; those stay culled (and the
        ones it sees stay kept) until unfrozen (a frozen view without a pygfx camera,
        e.g. the browser engine's, freezes no occlusion). ``camera`` may also be a
        :class:`~grasswidget.core.teaching.FrozenView` (e.g. another field's
        :attr:`frozen_camera`, or the browser engine's frozen camera; no viewport_size
        then). See :meth:`unfreeze_culling`.
        """
        if isinstance(camera, FrozenView):
            frozen = camera
        elif viewport_size is None:
            raise GrassValueError("viewport_size must be (width, height) > 0 pixels of the camera's view; got None")
        else:
            frozen = FrozenCamera(camera, viewport_size)
        to_local = np.linalg.inv(np.asarray(self.world.matrix, np.float64))
        if self.frustum_lines is not None:
            self.remove(self.frustum_lines)
        self._frozen_camera = frozen
        self.frustum_lines = frustum_line(frozen, to_local)
        self.add(self.frustum_lines)
        self._write_cull_uniform()
        # Occlusion freezes too: the next render_frame first captures what the frozen view hides.
        self.occlusion.capture_camera = frozen.camera

    def unfreeze_culling(self):
        """Cull against the camera of each render again (and remove the frustum lines)."""
        if self.frustum_lines is not None:
            self.remove(self.frustum_lines)
        self.frustum_lines = None
        self._frozen_camera = None
        self.occlusion.capture_camera = None
        self._write_cull_uniform()

    # ------------------------------------------------------------------ inspector

    def inspect(self, ids):
        """Draw these blades' control points v0, v1, v2, control polygon and the
        forces of the current step on v2 (gravity, recovery, wind, and the
        collision push when a sphere touches) as arrows, every frame, from the GPU
        state (see :mod:`grasswidget.gpu.inspector`). ``[]`` clears.

        At most 64 ids, each an integer in [0, count - 1]; anything else raises
        ValueError naming the limit and changes nothing.
        """
        from .inspector import BladeInspector
        from ..core.teaching import check_inspect_ids

        check_inspect_ids(ids, self.count)
        if self.inspector is None:
            self.inspector = BladeInspector(self)
            self.add(self.inspector)
        self.inspector.set_ids(ids)

    @property
    def inspected(self) -> tuple:
        """Ids of the blades shown by the inspector (empty when none)."""
        return self.inspector.ids if self.inspector is not None else ()

    def read_inspected(self) -> list:
        """The inspected blades' numbers as of the last render (one small readback):
        see :meth:`grasswidget.gpu.inspector.BladeInspector.read`."""
        return self.inspector.read() if self.inspector is not None else []

    # ------------------------------------------------------------------ frozen culling (state)

    @property
    def culling_frozen(self) -> bool:
        """True while the field culls against a frozen camera (:meth:`freeze_culling`)."""
        return self._frozen_camera is not None

    @property
    def frozen_camera(self):
        """The :class:`~grasswidget.gpu.frozen_camera.FrozenCamera` culled against, or None."""
        return self._frozen_camera

    # ------------------------------------------------------------------ simulation

    def set_wind_wgsl(self, body: str, select: bool = True):
        """Use a WGSL snippet as the wind: the body of
        ``fn user_wind(p: vec3<f32>, t: f32) -> vec3<f32>`` (p: blade root in the
        field's local space, metres; t: time in seconds; returns W in m/s^2).

        Compiles now. On a compile error raises :class:`WindShaderError` whose
        ``line`` is the line within ``body``, and keeps the previous wind (and
        ``params.wind_wgsl``) in force. On success sets ``params.wind_wgsl`` and,
        with ``select``, ``params.wind_field = "custom"``. Same as assigning
        ``params.wind_wgsl`` (which compiles in every field using those params).
        The snippet may call any function of ``grasswidget/shaders/blade_math.wgsl`` (e.g.
        ``simplex_noise2(x, y)``, ``wind_wave(...)``) and read the simulation
        uniforms (e.g. ``u_sim.wind_strength``). Example::

            field.set_wind_wgsl("return vec3<f32>(8.0 * (1.0 + sin(t + 0.3 * p.x)), 0.0, 0.0);")
        """
        if not isinstance(body, str):
            raise GrassTypeError(f"wind_wgsl must be a str (WGSL function body); got {type(body).__name__}")
        self.params.wind_wgsl = body
        if self.simulation.wind_body != body:  # params unchanged but never compiled here
            self.simulation.compile_wind(body, self.params.wind_wgsl)
        if select:
            self.params.wind_field = "custom"

    @property
    def function_overrides(self):
        """The :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides` in force (user WGSL
        replacing blade-math functions in the simulation, culling and inspector shaders), or
        None (the stock functions). Set with :meth:`set_function_overrides`."""
        return self._store.function_overrides

    def set_function_overrides(self, overrides):
        """Replace blade-math functions (e.g. an exercise's ``wind_force``) with user WGSL in
        this field's simulation, culling and inspector shaders; None restores the stock ones.

        ``overrides``: a :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides`. Checked
        (:meth:`~grasswidget.core.wgsl_overrides.FunctionOverrides.check`) and compiled now (the
        simulation shader holds every blade-math function, so the culling compiles too); on an
        error raises :class:`~grasswidget.errors.ExerciseShaderError` with the user's line and
        column and keeps the functions in force before the call.
        """
        from ..core.shader_files import render_wgsl
        from ..core.wgsl_overrides import FunctionOverrides

        if overrides is not None and not isinstance(overrides, FunctionOverrides):
            raise GrassTypeError(f"overrides must be a FunctionOverrides or None; got {type(overrides).__name__}")
        if overrides == self.function_overrides:
            return
        if overrides is not None:
            overrides.check(render_wgsl("blade_math.wgsl"))
        old = self._store.function_overrides
        self._store.function_overrides = overrides
        try:
            self.simulation.compile_now(self.params.wind_wgsl, blame="overrides")
        except BaseException:
            self._store.function_overrides = old
            raise

    def step(self, n: int = 1):
        """Advance the physics by ``n`` fixed steps of ``params.dt`` (n >= 0).

        The steps run in one dispatch of one GPU submission (the loop is in the shader;
        blades are independent) up to ``core.engine_inputs.BLADE_STEPS_PER_DISPATCH`` blade
        steps, in several beyond. Step k uses wind time ``(k * dt) mod wind_period`` like
        the NumPy reference.

        ``n`` is an integer in [0, MAX_STEPS] (1,000,000, :mod:`grasswidget.core.limits`); more
        raises a GrassValueError naming the limit. Ctrl-C between two submissions stops there
        and raises :class:`~grasswidget.core.limits.StepsInterrupted` (a KeyboardInterrupt),
        with ``step_count`` counting the steps that ran.
        """
        self.simulation.step(check_steps(n))

    @property
    def closed(self) -> bool:
        """True once :meth:`release` ran: every method but ``release`` then raises WidgetClosedError."""
        return self._released

    def release(self):
        """Free this field's GPU memory now (a second call does nothing); the field cannot
        be drawn or stepped afterwards: its methods raise WidgetClosedError."""
        if self._released:
            return
        self._released = True
        self._params_observer.stop()
        if self.stats is not None:
            self.stats.release()
            self.stats = None
        if self.inspector is not None:
            self.inspector.release()
        names = ("blade_buffer", "args_buffer", "visible_buffer", "cull_uniform", "collision_buffer",
                 "culled_args_buffer", "culled_buffer", "band_buffer", "occlusion_flags_buffer",
                 "occlusion_args_buffer", "raster_list_buffer", "raster_args_buffer", "raster_depth_buffer",
                 "raster_payload_buffer", "raster_color_buffer", "raster_dispatch_buffer")
        destroy_buffers([self._store[name] for name in names] + list(self._store.raster_retired))
        self._store.raster_retired = []
        self.occlusion.release()
        self.simulation.release()

    def enable_stats(self):
        """Create (once) and return this field's non-blocking FrameStats."""
        if self.stats is None:
            from .stats import FrameStats

            self.stats = FrameStats(self)
        return self.stats

    # ------------------------------------------------------------------ finite state

    @property
    def reset_flag_offset(self) -> int:
        """Byte offset in ``collision_buffer`` of the flag simulate.wgsl sets (1.0) when its
        finite check put a blade back at rest (after the N collision strengths)."""
        return 4 * self.count

    def check_finite(self) -> bool:
        """Whether the simulation put blades back at rest since the last check because their
        state went non-finite (a wind WGSL returning NaN or inf); warns once per cause
        (:class:`~grasswidget.core.limits.NonFiniteStateWarning`). One 4-byte synchronous
        readback: for after a run, not per frame (``read_state`` and the frame stats read the
        flag anyway)."""
        raw = ensure_device().queue.read_buffer(sync_buffer(self.collision_buffer), self.reset_flag_offset, 4)
        return self.note_reset_flag(float(np.frombuffer(raw, np.float32)[0]))

    def note_reset_flag(self, value: float) -> bool:
        """Handle the reset flag as read back from the GPU (any readback that has it): when set,
        clear it, count it in ``nonfinite_resets`` and warn (once per cause, until the wind or
        the blades are reset). Returns whether it was set."""
        if not value:
            return False
        ensure_device().queue.write_buffer(sync_buffer(self.collision_buffer), self.reset_flag_offset,
                                           np.zeros(1, np.float32).tobytes())
        self.nonfinite_resets += 1
        overrides = self.function_overrides is not None
        cause = nonfinite_cause(self.params, overrides)
        if cause != self._warned_cause:
            self._warned_cause = cause
            warn_nonfinite(nonfinite_message(self.params, overrides))
        return True

    def reset(self):
        """Put every blade back in its rest pose, collision strengths and the step counter to 0."""
        self.blade_buffer.data[:] = self.blades.packed().reshape(-1, 4)
        self.blade_buffer.update_full()
        self.collision_buffer.data[:] = 0.0
        self.collision_buffer.update_full()
        self.simulation.step_count = 0
        self._warned_cause = None

    # ------------------------------------------------------------------ readback

    def read_state(self) -> dict:
        """Copy the blade state from the GPU (synchronous).

        Returns a dict with "v0", "v1", "v2", "up" as (N, 3) float32 and "height",
        "width", "orientation", "stiffness", "collision" (eta, 0..1) as (N,) float32.
        """
        device = ensure_device()
        raw = device.queue.read_buffer(sync_buffer(self.blade_buffer))
        state = unpack_state(np.frombuffer(raw, np.float32).reshape(-1, 4, 4))
        raw = np.frombuffer(device.queue.read_buffer(sync_buffer(self.collision_buffer)), np.float32)
        state["collision"] = raw[: self.count].copy()
        self.note_reset_flag(float(raw[self.count]) if len(raw) > self.count else 0.0)
        return state

    def write_state(self, state: dict):
        """Upload a state dict (as returned by read_state) to the GPU (its "collision",
        if present, too). Every value must be finite (a GrassValueError names the first
        key that is not; nothing is written then)."""
        for key, value in state.items():
            arr = np.asarray(value)
            if arr.dtype.kind in "fc" and not np.isfinite(arr).all():
                bad = int(np.count_nonzero(~np.isfinite(arr)))
                raise GrassValueError(f"write_state: state[{key!r}] must be finite; {bad} of {arr.size} values "
                                      f"are NaN or inf")
        self.blade_buffer.data[:] = pack_state(state).reshape(-1, 4)
        self.blade_buffer.update_full()
        sync_buffer(self.blade_buffer)
        if "collision" in state:
            self.collision_buffer.data[: self.count] = np.asarray(state["collision"], np.float32).reshape(-1)
            self.collision_buffer.update_full()
            sync_buffer(self.collision_buffer)

    def read_draw_args(self) -> np.ndarray:
        """(LOD classes, 4) u32 draw arguments of the last render (synchronous); with
        occlusion culling the instance counts of both phases added."""
        first, second, _ = self._read_phase_args()
        first[:, 1] += second[:, 1]
        return first

    def _read_phase_args(self):
        device = ensure_device()
        first = np.frombuffer(device.queue.read_buffer(sync_buffer(self.args_buffer)), np.uint32)
        raw = np.frombuffer(device.queue.read_buffer(sync_buffer(self.occlusion_args_buffer)), np.uint32)
        second = raw.reshape(N_CLASSES + 1, 4)
        return first.reshape(N_CLASSES, 4).copy(), second[:N_CLASSES].copy(), int(second[N_CLASSES, 0])

    def read_occluded_count(self) -> int:
        """Blades culled by occlusion in the last render (0 without occlusion culling; synchronous)."""
        return self._read_phase_args()[2]

    def read_visible(self, draw_order: bool = False):
        """Ids of the blades drawn by the last render (synchronous): sorted, or with
        ``draw_order=True`` a list per LOD class in the order they were drawn (with
        occlusion culling: the first phase's, then the second's)."""
        device = ensure_device()
        first, second, _ = self._read_phase_args()
        visible = compat.gpu_buffer(self.visible_buffer)
        if visible is None:
            return [np.zeros(0, np.uint32)] * N_CLASSES if draw_order else np.zeros(0, np.uint32)
        raw = device.queue.read_buffer(visible)
        ids = np.frombuffer(raw, np.uint32).reshape(N_CLASSES, self.count)
        n = self.count
        lists = [np.concatenate([ids[k, : first[k, 1]], ids[k, n - second[k, 1]:][::-1]]) for k in range(N_CLASSES)]
        if draw_order:
            return lists
        return np.sort(np.concatenate(lists + [self.read_rastered()]))

    def read_rastered(self) -> np.ndarray:
        """Ids of the blades the compute rasterizer drew in the last render, in list order
        (synchronous; empty while it is off)."""
        count = self.read_raster_count() if self.compute_raster_active else 0
        if count == 0:
            return np.zeros(0, np.uint32)
        raw = ensure_device().queue.read_buffer(sync_buffer(self.raster_list_buffer), 0, 4 * count)
        return np.frombuffer(raw, np.uint32).copy()

    def read_seen(self) -> np.ndarray:
        """bool (N,): the blades that passed every culling test, occlusion included, in
        the last frame with occlusion culling (what the next first phase draws; synchronous)."""
        raw = np.frombuffer(ensure_device().queue.read_buffer(sync_buffer(self.occlusion_flags_buffer)), np.uint32)
        bits = np.unpackbits(raw.view(np.uint8), bitorder="little").astype(bool)
        return bits[: self.count]

