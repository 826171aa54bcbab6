"""GrassScene: a ready-made pygfx scene (renderer, camera, light, ground, field).

Renders offscreen when there is no screen; ``render()`` returns pixels and never
advances time; ``step(n)`` advances the physics by n fixed steps.
"""

from __future__ import annotations

import math
import time
import weakref

import numpy as np
import pygfx as gfx

from .. import compat
from ..core.blades import Blades
from ..errors import GrassTypeError, GrassValueError, refuse_when_closed
from .adapter import announce_cpu_defaults, ensure_device, is_cpu_adapter
from .collider_view import ColliderBalls
from .compute_ddaa import use_compute_ddaa
from .field import GrassField, GrassMaterial, check_blade_count_fits
from .frame import render_frame
from ..core import engine_inputs
from ..core.camera_rules import DEFAULT_FAR, DEFAULT_FOV_DEG, DEFAULT_NEAR, default_camera
from ..core.engine_inputs import SKY_GROUND_TRAITS, ground_square, sky_ground_values, sun_direction
from ..core.presets import PRESETS, parse_size, preset_field, preset_params  # pure helpers, re-exported here
from ..core.presets import check_png_path
from .sky_ground import GroundSwitch, SkyGround, SkyGroundMaterial
from ..core.observers import WeakObserver
from ..core.params import GrassParams, sunlight_defaults

__all__ = ["GrassScene", "parse_size", "PRESETS", "set_vertical_fov", "preset_field", "make_renderer",
           "adapter_params", "GPU_COMPUTE_RASTER_MAX_PX"]

#: The cis565 preset's distance-culling reach (m) when it makes its own params.
CIS565_DISTANCE_MAX = preset_params("cis565")["cull_distance_max"]

#: ``compute_raster_max_px`` of the params a GrassScene makes on a GPU adapter (pixels;
#: GrassParams' own default is 2). Measured on an H100 (meadow 1920x1080, culled,
#: benchmarks/README.md): 4 px sends ~60 % of the visible blades at 2^20 to the compute
#: rasterizer (2 px: 9 %) and the frame rate rises from 116 to 139 frames/s at 2^20 and from 69
#: to 84 at 2^24; the picture with it stays within 0.62 (0..255, 4 x 4-pixel block means)
#: of the hardware-only one (2 px: 0.09; 6 px: 1.12 and visibly grainier far grass for few
#: more frames).
GPU_COMPUTE_RASTER_MAX_PX = 4.0


#: Renderers that have drawn a frame (see compat.keep_renderstates).
_RENDERERS_DRAWN: weakref.WeakSet = weakref.WeakSet()


def adapter_params(**values) -> GrassParams:
    """GrassParams with this adapter's defaults for what GrassScene makes itself: the
    compute rasterizer's width limit on a GPU adapter (``compute_raster_max_px``
    :data:`GPU_COMPUTE_RASTER_MAX_PX`; whether it runs is ``compute_raster`` "auto", decided
    by measuring, :mod:`grasswidget.core.auto_switches`), and the sunlight's shadows on a GPU adapter,
    off on a CPU adapter (:func:`grasswidget.core.params.sunlight_defaults`); ``values`` set
    any params besides."""
    gpu = not is_cpu_adapter()
    defaults = dict(compute_raster_max_px=GPU_COMPUTE_RASTER_MAX_PX) if gpu else {}
    defaults.update(sunlight_defaults(cpu_adapter=not gpu))  # shadows where affordable (a GPU)
    return GrassParams(**{**defaults, **values})


def set_vertical_fov(camera, fov_deg, aspect):
    """Give a pygfx PerspectiveCamera a true vertical field of view.

    pygfx applies ``fov`` to the mean of width and height; this picks the pygfx
    fov whose vertical extent is ``fov_deg`` at the given aspect (w / h).
    """
    half = math.atan(math.tan(math.radians(fov_deg) / 2) * (1 + aspect) / 2)
    camera.fov = math.degrees(2 * half)
    camera.aspect = aspect


def make_renderer(canvas, *, export=False):
    """A pygfx WgpuRenderer for ``canvas`` with this project's per-adapter settings.

    Live view (``export=False``): pixel ratio 1, no post-process anti-aliasing on a
    CPU adapter (pygfx's default one on a GPU), no picking events. Export
    (``export=True``): anti-aliased on every adapter: rendered at
    :data:`~grasswidget.core.engine_inputs.EXPORT_SUPERSAMPLE` times the size in each direction and filtered down
    (supersampling), plus pygfx's default post-process anti-aliasing on a GPU.
    ``canvas``: a rendercanvas canvas or a pygfx Texture (offscreen, as the benchmarks use).

    pygfx's default anti-aliasing (DDAA) runs in a compute pass
    (:mod:`grasswidget.gpu.compute_ddaa`: the same shader, the same picture within one level
    of 255, a fraction of its cost on a GPU whose pixel work is narrow).
    """
    cpu = is_cpu_adapter()
    if cpu:
        announce_cpu_defaults()
    ratio = engine_inputs.EXPORT_SUPERSAMPLE if export else 1
    renderer = gfx.WgpuRenderer(canvas, pixel_ratio=ratio, ppaa="none" if cpu else "default", enable_events=False)
    use_compute_ddaa(renderer)
    # The sky covers every pixel (opaque): the output pass is a texture copy where it copies exactly.
    compat.copy_output_when_exact(renderer)
    return renderer


@refuse_when_closed("GrassScene")
class GrassScene:
    """A field of grass in a scene with a camera, a light and a ground plane.

    Args:
        blades: a :class:`Blades` or a blade count (then ``Blades.on_plane(count)``).
        size: (width, height) of the image in pixels (default 640 x 480).
        params: a :class:`GrassParams` (default: a new one).

    Attributes: ``params``, ``camera`` (a pygfx PerspectiveCamera), ``field``
    (the :class:`GrassField`), ``scene`` (the pygfx Scene), ``renderer``, ``canvas``,
    ``sky_ground`` (a :class:`~grasswidget.gpu.sky_ground.SkyGround`: the sky
    gradient and a flat ground square in one full-screen pass), ``ground``
    (``ground.visible`` switches the ground square), ``collider_balls`` (a
    :class:`~grasswidget.gpu.collider_view.ColliderBalls`: every sphere in
    ``colliders`` is drawn as a translucent ball; ``show_colliders = False`` hides them).
    """

    def __init__(self, blades, size=(640, 480), params: GrassParams | None = None, *, canvas=None):
        self._released = False
        if isinstance(blades, (int, np.integer)) and not isinstance(blades, bool):
            if blades < 1:
                raise GrassValueError(f"blades must be a blade count >= 1 or a Blades; got {blades!r}")
            blades = Blades.on_plane(check_blade_count_fits(blades, "blades"))
        if not isinstance(blades, Blades):
            raise GrassTypeError(f"blades must be a Blades or a blade count, not {type(blades).__name__}")
        self.size = parse_size(size)
        ensure_device()
        if params is None:  # the compute rasterizer where it is faster: a GPU adapter (see GrassParams.compute_raster)
            params = adapter_params()
        self.field = GrassField(blades, params=params, material=GrassMaterial())
        self.params = self.field.params

        self.scene = gfx.Scene()
        # Sky and a flat ground square in one full-screen pass (sized by _fit_ground).
        centre, half = ground_square(blades, None)
        self.sky_ground = SkyGround(SkyGroundMaterial(ground_center=centre, ground_half_size=half))
        self.ground = GroundSwitch(self.sky_ground.material)
        self.field.material.fog_color = self.sky_ground.material.horizon_color  # far grass meets the sky
        # Weakly: the params may be shared and outlive this scene (core.observers).
        self._observers = [WeakObserver(self.params, self._write_sky_ground, names=list(SKY_GROUND_TRAITS))]
        self.scene.add(self.sky_ground)
        self.scene.add(self.field)
        # Colliders live in the field's local space: the balls follow the field's transform
        # (ColliderBalls.sync). A direct child of the scene, drawn after the occlusion
        # culling's second phase (render_frame's late objects: translucent, no depth).
        self.collider_balls = ColliderBalls(self.field)
        self.scene.add(self.collider_balls)
        self.scene.add(gfx.AmbientLight(intensity=0.6))
        # A pygfx DirectionalLight that skips pygfx's per-render re-aiming while it stands
        # still (compat.still_directional_light_class: 0.6 ms of host work a frame on lavapipe's host).
        sun = compat.still_directional_light_class()(intensity=2.0)
        self.scene.add(sun)
        self.light = sun
        self._aim_sun()  # the params' sun (core.engine_inputs.sun_direction), both engines
        self._observers.append(WeakObserver(self.params, self._aim_sun, names=["sun_elevation", "sun_azimuth"]))

        self.camera = gfx.PerspectiveCamera(DEFAULT_FOV_DEG, self.size[0] / self.size[1],
                                            depth_range=(DEFAULT_NEAR, DEFAULT_FAR))
        set_vertical_fov(self.camera, DEFAULT_FOV_DEG, self.size[0] / self.size[1])
        self.preset_name = None
        self._default_view(blades.v0)
        self._fit_ground()

        if canvas is None:
            from rendercanvas.offscreen import RenderCanvas

            canvas = RenderCanvas(size=self.size, pixel_ratio=1)
        self.canvas = canvas
        self.renderer = make_renderer(canvas)
        self.stats = self.field.enable_stats()
        canvas.request_draw(self.draw_frame)

    @classmethod
    def preset(cls, name, blades=None, size=None, params=None, seed=0, horizon=True, **kwargs):
        """A named scene.

        - ``"cis565"``: the CIS 565 course scene, to compare with the seed projects:
          a 15 x 15 plane at y = 0, blades h 1.3-2.5, w 0.1-0.14, stiffness 7-13,
          camera at (0, 1, 10) looking at (0, 1, 0), vertical fov 45 degrees, near
          0.1, far 100, 640 x 480. Default 2^13 blades. With ``params=None`` its
          distance culling reaches zero at 40 m (``cull_distance_max``; the
          paper's 100 is for fields of hundreds of metres): the far corner is 18 m
          away, so up to 46% of the far blades go, where the near grass hides them
          (0.2% of the pixels of the 2^16 view change, all in the gaps at the top).
        - ``"meadow"``: a wide field of meadow grass (h 0.5-1.0 m, w 0.02-0.04 m)
          at about 1000 blades per m^2 (side sqrt(N / 1000) m, 15..250 m), seen from
          3 m above its edge, 1920 x 1080. Default 2^20 blades. With ``horizon`` (the
          default) it reaches the horizon and follows the camera: the same blade count in
          levels of tiles around the camera, the nearest at the square field's density where
          the count allows (at least as many blades within 10 m of the camera as the square
          field had from its home camera), the farther ones thinner and wider, out to about
          200 m (half the far plane; ``Blades.on_plane(..., reach=200)``), on ground coloured
          like the grass seen from afar; the camera may go anywhere within 200 m of the middle.
          ``horizon=False`` gives the square field alone on a bare ground, as before.
        """
        if name not in PRESETS:
            raise GrassValueError(f"preset must be one of {', '.join(PRESETS)}; got {name!r}")
        if blades is not None and not isinstance(blades, Blades):
            if isinstance(blades, bool) or not isinstance(blades, (int, np.integer)) or blades < 1:
                raise GrassValueError(f"blades must be a blade count >= 1, a Blades or None; got {blades!r}")
            blades = check_blade_count_fits(blades, "blades")  # before any blade is made
        if params is None:
            params = adapter_params(**preset_params(name))
        b, default_size, view = preset_field(name, blades, seed, horizon=horizon)
        scene = cls(b, size=size or default_size, params=params, **kwargs)
        scene._set_view(view["position"], view["target"], fov=view["fov_deg"], near=view["near"], far=view["far"])
        scene.preset_name = name
        return scene

    def _set_view(self, position, target, fov, near, far):
        self.camera.local.position = position
        self.camera.look_at(target)
        self.camera.depth_range = (near, far)
        set_vertical_fov(self.camera, fov, self.size[0] / self.size[1])
        self._home = (np.array(self.camera.local.position), np.array(self.camera.local.rotation))
        self._fit_ground()

    def _fit_ground(self):
        """Size the ground plane to reach the far plane from anywhere over the field,
        so that a low camera sees ground, not sky, below the horizon; the ground fades
        into the horizon towards the far plane."""
        self._write_sky_ground()

    def _write_sky_ground(self, change=None):
        """Write the sky/ground values both engines use
        (:func:`grasswidget.core.engine_inputs.sky_ground_values`: the ground square to the
        far plane, the soil under this field, the params' fog), keeping ``ground.visible``."""
        far = float(self.camera.depth_range[1]) if self.camera.depth_range else None
        self.sky_ground.material.set_values(sky_ground_values(self.field.blades, far, self.params,
                                                              show_ground=self.ground.visible))

    def _aim_sun(self, change=None):
        """The scene's light (it lights the balls) from the params' sun."""
        self.light.local.position = tuple(10.0 * x for x in sun_direction(self.params))

    def look(self, position=None, target=None, fov_deg=None):
        """Aim the camera: from ``position`` at ``target`` (metres, world space) with a
        vertical field of view of ``fov_deg`` degrees; None keeps that part (a None
        target keeps the viewing direction). The home view (reset_camera) is kept."""
        cam = self.camera
        if position is not None:
            forward = -np.asarray(cam.world.matrix, np.float64)[:3, 2]
            cam.local.position = tuple(float(x) for x in position)
            if target is None:
                target = np.asarray(position, np.float64) + forward
        if target is not None:
            cam.look_at(tuple(float(x) for x in target))
        if fov_deg is not None:
            set_vertical_fov(cam, float(fov_deg), self.size[0] / self.size[1])

    def vertical_fov(self) -> float:
        """The camera's vertical field of view in degrees (the inverse of set_vertical_fov)."""
        aspect = self.size[0] / self.size[1]
        half = math.radians(self.camera.fov) / 2
        return math.degrees(2 * math.atan(2 * math.tan(half) / (1 + aspect)))

    @property
    def show_colliders(self) -> bool:
        """Draw each sphere collider as a translucent ball (default True)."""
        return self.collider_balls.visible

    @show_colliders.setter
    def show_colliders(self, value):
        if not isinstance(value, (bool, np.bool_)):
            raise GrassTypeError(f"show_colliders must be True or False; got {value!r}")
        self.collider_balls.visible = bool(value)

    colliders = property(
        lambda self: self.field.colliders,
        lambda self, value: setattr(self.field, "colliders", value),
        doc="Sphere colliders acting on the grass: GrassField.colliders (gw.SphereCollider items plus colliders.set_array rows, at most 1024).",
    )

    # ------------------------------------------------------------------ views

    def _default_view(self, v0):
        # core.camera_rules.default_camera: the browser engine's home view too
        home = default_camera(v0)
        self.camera.local.position = tuple(home["position"])
        self.camera.look_at(tuple(home["target"]))
        self._home = (np.array(self.camera.local.position), np.array(self.camera.local.rotation))

    def reset_camera(self):
        """Put the camera back where the scene started."""
        self.camera.local.position, self.camera.local.rotation = self._home

    # ------------------------------------------------------------------ teaching views

    def viewport_size(self) -> tuple:
        """(width, height) in physical pixels of the scene's view (its renderer's
        target; the asked ``size`` while the canvas has none yet)."""
        try:
            w, h = self.renderer.physical_size
        except Exception:
            w = h = 0
        return (int(w), int(h)) if w > 0 and h > 0 else tuple(self.size)

    def freeze_culling(self):
        """Freeze culling at the current camera: from now on the field culls and
        picks LOD classes against a copy of this camera (pose, projection,
        viewport), however the camera moves, and the copy's view volume is drawn
        as white lines. Fly out (e.g. above the field) to see what the frozen view
        keeps; with ``params.color_by = "cull"`` every culled blade shows the test
        that culled it. Freezing again takes a new copy. See :meth:`unfreeze_culling`.
        """
        self.field.freeze_culling(self.camera, self.viewport_size())

    def unfreeze_culling(self):
        """Cull against the rendering camera again (the default)."""
        self.field.unfreeze_culling()

    @property
    def culling_frozen(self) -> bool:
        """True between :meth:`freeze_culling` and :meth:`unfreeze_culling`."""
        return self.field.culling_frozen

    def inspect(self, ids):
        """Show up to 64 blades in the blade inspector: v0, v1, v2 as dots, the
        control polygon, and arrows for the forces of the current step on v2
        (gravity: violet, recovery: cyan, wind: red; an acceleration of 20 m/s^2
        is as long as the blade) and the push of a touching sphere in this step
        (amber, drawn 10 times its length), every frame from the GPU state. ``inspect([])`` clears. Ids out of range, more than 64 ids
        or non-integers raise ValueError naming the limit. See GrassField.inspect.
        """
        self.field.inspect(ids)

    @property
    def inspected(self) -> tuple:
        """Ids of the inspected blades."""
        return self.field.inspected

    def read_inspected(self) -> list:
        """Numbers of the inspected blades as of the last render: GrassField.read_inspected."""
        return self.field.read_inspected()

    # ------------------------------------------------------------------ time

    def step(self, n: int = 1):
        """Advance the physics by n fixed steps, n in [0, MAX_STEPS] (1,000,000; see GrassField.step:
        a larger n raises a GrassValueError naming MAX_STEPS, Ctrl-C stops between submissions)."""
        self.field.step(n)

    # ------------------------------------------------------------------ pictures

    def draw_frame(self):
        """Render one frame into the scene's canvas (its draw function); feeds ``stats``.
        Never advances time."""
        t0 = time.perf_counter()
        self.draw_into(self.renderer)
        self.stats.after_render((time.perf_counter() - t0) * 1000.0)

    def draw_into(self, renderer):
        """Render the scene with its camera through ``renderer`` (any pygfx WgpuRenderer:
        the scene's own, an offscreen one), occlusion culling included
        (:func:`grasswidget.gpu.frame.render_frame`). Never advances time."""
        self.collider_balls.sync()
        render_frame(renderer, self.scene, self.camera, late=[self.collider_balls])
        if renderer not in _RENDERERS_DRAWN:  # its first frame made its render state: keep it for the next renderers
            _RENDERERS_DRAWN.add(renderer)
            compat.keep_renderstates()

    def render(self) -> np.ndarray:
        """Render the current state; returns (h, w, 4) uint8 RGBA. Never advances time."""
        img = self.canvas.draw()
        return np.asarray(img)

    def render_at(self, size=None, *, antialias=True) -> np.ndarray:
        """Render at ``size`` (w, h) pixels (default the scene's) offscreen, same camera
        and state; (h, w, 4) uint8. Never advances time. ``antialias=True`` (default,
        what exports use): supersampled, see :func:`make_renderer`; False: like the
        live view."""
        from rendercanvas.offscreen import RenderCanvas

        w, h = self.size if size is None else parse_size(size)
        canvas = RenderCanvas(size=(w, h), pixel_ratio=1)
        renderer = make_renderer(canvas, export=bool(antialias))
        aspect = self.camera.aspect
        canvas.request_draw(lambda: self.draw_into(renderer))
        try:
            return np.asarray(canvas.draw())
        finally:
            self.camera.aspect = aspect
            canvas.close()

    def save_png(self, path, size=None) -> str:
        """Write an anti-aliased PNG of the current state (default: the scene's size;
        see :meth:`render_at`); returns the path. ``path`` must end in ``.png`` and its
        folder exist (checked before anything is rendered)."""
        import imageio.v3 as iio

        path = check_png_path(path)
        img = self.render_at(size)
        iio.imwrite(path, img, extension=".png")
        return path

    @property
    def closed(self) -> bool:
        """True once :meth:`release` ran: every method but ``release`` then raises WidgetClosedError."""
        return self._released

    def release(self):
        """Free the field's GPU memory now and drop the renderer and canvas (a second call
        does nothing); the scene cannot be drawn or stepped afterwards: its methods raise
        WidgetClosedError."""
        if self._released:
            return
        self._released = True
        # The params may outlive the scene (a widget's next scene shares them): stop following them now.
        for observer in self._observers:
            observer.stop()
        self.field.release()
        self.sky_ground.cache.release()
        try:
            self.scene.remove(self.field)
        except Exception:
            pass
        self.renderer = None
        self.canvas = None

    # ------------------------------------------------------------------ stats

    def visible_count(self) -> int:
        """Blades drawn by the last render, as ribbons or by the compute rasterizer
        (synchronous GPU readback; see :meth:`drawn_counts`)."""
        return sum(self.drawn_counts().values())

    def drawn_counts(self) -> dict:
        """Blades the last render drew by each path (synchronous GPU readback):
        {"hardware": ribbons, "compute": the compute rasterizer's (GrassParams.compute_raster)}."""
        return {"hardware": int(self.field.read_draw_args()[:, 1].sum()),
                "compute": self.field.read_raster_count()}
