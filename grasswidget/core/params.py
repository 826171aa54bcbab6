"""Simulation, wind and culling parameters as one validated traitlets object.

``GrassParams`` is pure Python (no GPU import). Every numeric trait refuses NaN,
inf and values outside its documented range (every choice trait, values outside
its choices) with a ``ParameterError``, both a traitlets ``TraitError`` and a
``ValueError``, whose message names the trait, its unit and the allowed range;
the previous value stays in force. ipywidgets can ``link`` to these traits directly.
"""

from __future__ import annotations

import difflib
import math

import numpy as np
import traitlets
from traitlets import Bool, HasTraits, Unicode

from .limits import MAX_COORDINATE
from .auto_switches import AutoSwitch
from .enums import BladeShape, ColorBy, GravityMode, WindField
from ..errors import ParameterError, UnknownNameError

__all__ = [
    "CheckedBool", "GrassParams", "LOOK_TRAITS", "SUN_TRAITS", "DEFAULT_SUN_DIRECTION", "sunlight_defaults", "StrictTraits", "ParameterError", "RangedFloat", "RangedInt", "Vec3",
    "WIND_FIELDS", "BLADE_SHAPES", "GRAVITY_MODES", "COLOR_BY",
]

#: Wind fields understood by the simulation (see ``reference.wind_field``; ids: ``enums.WindField``).
WIND_FIELDS = WindField.labels()
#: Ribbon shapes of the paper (see ``GrassMaterial.blade_shape``; ids: ``enums.BladeShape``).
BLADE_SHAPES = BladeShape.labels()
#: How environmental gravity is aimed (see ``reference.environmental_gravity``; ids: ``enums.GravityMode``).
GRAVITY_MODES = GravityMode.labels()
#: How blades are coloured (see ``GrassParams.color_by`` and ``grasswidget.core.teaching``; ids: ``enums.ColorBy``).
COLOR_BY = ColorBy.labels()

#: The traits that change only how the meadow looks (blade colour, fog), not the physics.
LOOK_TRAITS = ("color_variation", "patch_size", "dryness", "translucency", "fog_density")
#: The traits of the sunlight (drawing only): the shadows' switch and the sun's direction.
SUN_TRAITS = ("shadows", "sun_elevation", "sun_azimuth")
#: Direction towards the sun of the default params (world space, not normalized), both engines:
#: elevation 63.4 degrees, azimuth 36.9 degrees (``sun_elevation`` and ``sun_azimuth``'s defaults;
#: the blade material's default light, ``core.engine_inputs.MATERIAL_DEFAULTS``).
DEFAULT_SUN_DIRECTION = (4.0, 10.0, 3.0)
_SUN_ELEVATION = math.degrees(math.atan2(DEFAULT_SUN_DIRECTION[1], math.hypot(DEFAULT_SUN_DIRECTION[0], DEFAULT_SUN_DIRECTION[2])))
_SUN_AZIMUTH = math.degrees(math.atan2(DEFAULT_SUN_DIRECTION[2], DEFAULT_SUN_DIRECTION[0]))


def sunlight_defaults(cpu_adapter: bool) -> dict:
    """The sunlight's defaults on an adapter (GrassScene, GrassWidget): ``shadows`` on where it is
    affordable, a GPU adapter; off on a CPU adapter (lavapipe, SwiftShader), where every pixel of
    grass and ground pays for it (benchmarks/sunlight_cost_lavapipe.json: 1.03-1.09x the live
    view's frame) and the far grass of the meadow to the horizon spends the CPU view's budget."""
    return {"shadows": not bool(cpu_adapter)}


class CheckedBool(Bool):
    """A True/False trait whose bad values raise a :class:`ParameterError` naming the trait
    (traitlets' ``Bool`` raises a bare ``TraitError``, which ``except ValueError`` misses).

    Takes ``True``/``False``, NumPy's booleans (``arr[0] > 0``) and the integers 0 and 1, as
    traitlets does; anything else (``"yes"``, ``None``, ``2``, ``0.5``) is refused and the
    previous value stays.
    """

    def validate(self, obj, value):
        if isinstance(value, np.bool_):
            return bool(value)
        if isinstance(value, (bool, int, np.integer)) and value in (0, 1):
            return bool(value)
        raise ParameterError(f"{self.name} must be True or False; got {value!r}")


class RangedFloat(traitlets.Float):
    """A float trait with an inclusive range that refuses NaN and inf.

    The error message names the trait, the allowed range and the unit, e.g.
    ``gravity must be a finite number in [0, 50] m/s^2; got nan``.
    """

    def __init__(self, default_value, lo, hi, unit="", **kwargs):
        self.lo, self.hi, self.unit = float(lo), float(hi), unit
        super().__init__(default_value, **kwargs)

    def range_text(self):
        unit = f" {self.unit}" if self.unit else ""
        return f"[{self.lo:g}, {self.hi:g}]{unit}"

    def validate(self, obj, value):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            import numpy as np

            if not (isinstance(value, np.generic) and np.issubdtype(type(value), np.number)):
                raise ParameterError(f"{self.name} must be a number in {self.range_text()}; got {value!r}")
            value = float(value)
        value = float(value)
        if not math.isfinite(value) or not (self.lo <= value <= self.hi):
            raise ParameterError(
                f"{self.name} must be a finite number in {self.range_text()}; got {value!r}"
            )
        return value


class RangedInt(traitlets.Int):
    """An integer trait with an inclusive range and a clear error message."""

    def __init__(self, default_value, lo, hi, unit="", **kwargs):
        self.lo, self.hi, self.unit = int(lo), int(hi), unit
        super().__init__(default_value, **kwargs)

    def validate(self, obj, value):
        unit = f" {self.unit}" if self.unit else ""
        ok = isinstance(value, int) and not isinstance(value, bool)
        if not ok:
            try:
                import numpy as np

                ok = isinstance(value, np.integer)
            except ImportError:  # pragma: no cover
                ok = False
        if not ok or not (self.lo <= int(value) <= self.hi):
            raise ParameterError(
                f"{self.name} must be an integer in [{self.lo}, {self.hi}]{unit}; got {value!r}"
            )
        return int(value)


class ChoiceTrait(Unicode):
    """A string trait limited to a set of choices, with a clear error message."""

    def __init__(self, default_value, choices, **kwargs):
        self.choices = tuple(choices)
        super().__init__(default_value, **kwargs)

    def validate(self, obj, value):
        if not isinstance(value, str) or value not in self.choices:
            raise ParameterError(
                f"{self.name} must be one of {', '.join(map(repr, self.choices))}; got {value!r}"
            )
        return value


class Vec3(traitlets.TraitType):
    """A 3-vector trait: any sequence of 3 finite numbers, stored as a tuple of floats.

    With ``nonzero=True`` the zero vector is refused too; with ``limit`` every
    component must lie in [-limit, limit] (a position the float32 physics can take,
    :data:`grasswidget.core.limits.MAX_COORDINATE`). The error message names the
    trait, e.g. ``wind_center must be 3 finite numbers (x, y, z) in m, each in
    [-1e+07, 1e+07]; got ...``.
    """

    default_value = (0.0, 0.0, 0.0)
    info_text = "a 3-vector of finite numbers"

    def __init__(self, default_value=(0.0, 0.0, 0.0), nonzero=False, unit="", limit=None, **kwargs):
        self.nonzero, self.unit = nonzero, unit
        self.limit = None if limit is None else float(limit)
        super().__init__(tuple(float(x) for x in default_value), **kwargs)

    def validate(self, obj, value):
        unit = f" in {self.unit}" if self.unit else ""
        what = "a finite non-zero 3-vector" if self.nonzero else "3 finite numbers"
        if self.limit is not None:
            unit += f", each in [{-self.limit:g}, {self.limit:g}]"
        bad = ParameterError(f"{self.name} must be {what} (x, y, z){unit}; got {value!r}")
        if isinstance(value, (str, bytes)):
            raise bad
        try:
            items = list(value)
        except TypeError:
            raise bad from None
        if len(items) != 3 or any(isinstance(x, bool) for x in items):
            raise bad
        try:
            out = tuple(float(x) for x in items)
        except (TypeError, ValueError):
            raise bad from None
        if not all(math.isfinite(x) for x in out) or (self.nonzero and not any(out)):
            raise bad
        if self.limit is not None and any(abs(x) > self.limit for x in out):
            raise bad
        return out


def _unknown_name(obj, name) -> UnknownNameError:
    """An UnknownNameError (an AttributeError) for an unknown public name that suggests the closest trait."""
    kind = type(obj).__name__
    names = sorted(obj.trait_names())
    close = difflib.get_close_matches(name, names, n=1, cutoff=0.6)
    hint = f"; did you mean {close[0]!r}?" if close else f"; its traits are: {', '.join(names)}"
    err = UnknownNameError(f"{kind} has no trait {name!r}{hint}")
    err.name, err.obj = name, obj
    return err


class StrictTraits(HasTraits):
    """HasTraits that refuses unknown public attribute names.

    ``params.wind_strenght = 3`` (a typo) raises ``AttributeError: GrassParams has
    no trait 'wind_strenght'; did you mean 'wind_strength'?`` instead of quietly
    adding an attribute that nothing reads; so do unknown keyword arguments to the
    constructor and reading an unknown name. Names starting with ``_``, traits,
    and attributes defined on the class (methods, properties) work as usual.
    """

    def __init__(self, *args, **kwargs):
        for key in kwargs:
            if not self.has_trait(key) and not hasattr(type(self), key):
                raise _unknown_name(self, key)
        super().__init__(*args, **kwargs)

    def __setattr__(self, name, value):
        if not name.startswith("_") and not self.has_trait(name) and not hasattr(type(self), name):
            raise _unknown_name(self, name)
        super().__setattr__(name, value)

    def __getattr__(self, name):  # only called for names not found the usual way
        if name.startswith("_"):
            raise UnknownNameError(name)
        raise _unknown_name(self, name)


class GrassParams(StrictTraits):
    """All run-time parameters of a grass field (forces, wind, time step, culling).

    Units are SI: metres, seconds, m/s^2 for accelerations (the simulation moves
    the tip guide v2 by ``force * dt`` as in the paper, so "forces" are
    accelerations per unit of blade). Changes apply at the next ``step()`` (physics)
    or the next ``render()`` (culling, level of detail).
    """

    # ---- forces (paper section 5.1) -------------------------------------------
    gravity = RangedFloat(9.8, 0.0, 50.0, "m/s^2", help="Environmental gravity |gE| along gravity_direction.").tag(sync=True)
    front_gravity = RangedFloat(0.25, 0.0, 2.0, help="Front gravity factor: gF = front_gravity * |gE| * f (paper: 0.25).").tag(sync=True)
    stiffness_scale = RangedFloat(1.0, 0.01, 20.0, help="Multiplies each blade's stiffness s in the recovery force r = (iv2 - v2) s.").tag(sync=True)
    gravity_mode = ChoiceTrait("direction", GRAVITY_MODES, help='"direction": gE = normalize(gravity_direction) * gravity; "point": gE = normalize(gravity_center - v0) * gravity (grass on a planet).').tag(sync=True)
    gravity_direction = Vec3((0.0, -1.0, 0.0), nonzero=True, help="Direction of gravity in world space (normalised), used when gravity_mode is 'direction'. Any finite non-zero 3-vector: only its direction counts (normalised in float64, so (1e300, 0, 0) and (1e-300, 0, 0) both mean +x).").tag(sync=True)
    gravity_center = Vec3((0.0, 0.0, 0.0), unit="m", limit=MAX_COORDINATE, help="Point that pulls the blades (world space), used when gravity_mode is 'point'. Each coordinate in [-1e7, 1e7] m (grasswidget.core.limits.MAX_COORDINATE: a planet's centre fits).").tag(sync=True)

    # ---- collisions -------------------------------------------------------------
    collision_gain = RangedFloat(200.0, 0.0, 1e5, "1/m^2", help="Each collider push d adds collision_gain * |d|^2 to the blade's collision strength eta (clamped to 0..1). 1 is the paper's literal rule; at 120 steps/s the pushes are small, and the default 200 makes a rolling sphere leave a visible trail.").tag(sync=True)
    collision_fade = RangedFloat(0.15, 0.0, 100.0, "1/s", help="Rate at which a blade's collision strength eta (0..1) fades: eta -= collision_fade * dt each step. Recovery is scaled by max(1 - eta, 0.1), so a trampled trail stands back up within about 1 / collision_fade seconds.").tag(sync=True)

    # ---- wind -----------------------------------------------------------------
    wind_field = ChoiceTrait("wave", WIND_FIELDS, help="Wind field W(p, t): 'wave' (travelling gusts along wind_direction), 'radial' (away from wind_center, pulsing; helicopter downwash), 'vortex' (turning around the vertical axis through wind_center), 'noise' (simplex-noise gusts drifting along wind_direction) or 'custom' (the WGSL in wind_wgsl). See grasswidget.core.reference.").tag(sync=True)
    wind_strength = RangedFloat(5.0, 0.0, 200.0, "m/s^2", help="Peak wind acceleration |W|.").tag(sync=True)
    wind_direction = RangedFloat(0.0, -360.0, 360.0, "degrees", help="Direction the wind blows towards, in the ground plane: 0 = +x, 90 = +z.").tag(sync=True)
    wind_speed = RangedFloat(3.0, 0.0, 50.0, "m/s", help="Speed at which the wind wave travels along wind_direction.").tag(sync=True)
    wind_wavelength = RangedFloat(8.0, 0.1, 1000.0, "m", help="Distance between two gust crests (wave, radial and vortex pulses); the gust size of the noise field.").tag(sync=True)
    wind_center = Vec3((0.0, 0.0, 0.0), unit="m", limit=MAX_COORDINATE, help="Centre of the radial and vortex fields, in the field's local space (world space for an untransformed field). Each coordinate in [-1e7, 1e7] m (grasswidget.core.limits.MAX_COORDINATE: farther, the float32 distances to it overflow).").tag(sync=True)
    wind_radius = RangedFloat(5.0, 0.01, 1000.0, "m", help="Radial and vortex fields peak at this distance from wind_center and fall off beyond it.").tag(sync=True)
    wind_wgsl = Unicode("", help="Body of `fn user_wind(p: vec3<f32>, t: f32) -> vec3<f32>` (WGSL), used when wind_field is 'custom'. Empty: no wind. A GrassField compiles it when set and refuses (raises, keeps the old one) a snippet that does not compile.").tag(sync=True)

    # ---- drawing ----------------------------------------------------------------
    blade_shape = ChoiceTrait("triangle-tip", BLADE_SHAPES, help="Ribbon shape of the blades (paper section 6): quad, triangle, quadratic, triangle-tip or fold (3D).").tag(sync=True)

    # ---- looks (drawing only; the physics ignores them) ------------------------------
    color_variation = RangedFloat(0.35, 0.0, 1.0, help="How much the blades' colour (hue and brightness) varies, mostly in patches of patch_size: 0 every blade alike, 1 strong.").tag(sync=True)
    patch_size = RangedFloat(3.0, 0.1, 100.0, "m", help="Size of the meadow's colour patches (clumps of lighter, darker, drier grass).").tag(sync=True)
    dryness = RangedFloat(0.1, 0.0, 1.0, help="How much dry, straw-coloured grass there is, in patches (tips dry first): 0 none, 1 most of it.").tag(sync=True)
    translucency = RangedFloat(0.6, 0.0, 1.0, help="How much the tips light up when the sun is behind them (light through the blade): 0 not at all, 1 strongly.").tag(sync=True)
    shadows = CheckedBool(False, help="Sunlight with shadows: the balls' shadows on grass and ground, the grass' shadow on the ground beside it and on itself (the blades as a layer that lets exp(-depth) of the light through, depth from their leaf area per m^2 and the sun's height), and the roots darkened by the grass above them, more where the field is denser. Both engines. Off by default in GrassParams (a CPU adapter pays for it in every pixel of grass and ground); GrassScene and GrassWidget turn it on where it is affordable (grasswidget.gpu.scene.adapter_params). Off: the picture without shadows.").tag(sync=True)
    sun_elevation = RangedFloat(_SUN_ELEVATION, 5.0, 90.0, "degrees", help="The sun's height above the horizon: 90 straight up; lower suns cast longer shadows. Lights the blades, the ground and the balls in both engines.").tag(sync=True)
    sun_azimuth = RangedFloat(_SUN_AZIMUTH, -360.0, 360.0, "degrees", help="Where the sun stands in the ground plane, seen from the field: 0 = towards +x, 90 = towards +z (as wind_direction).").tag(sync=True)
    fog_density = RangedFloat(0.005, 0.0, 1.0, "1/m", help="Distance fog: a share exp(-fog_density * d) of the light from d metres away reaches the eye, the rest is the sky's colour at the horizon; 0 turns the fog off.").tag(sync=True)

    # ---- time -----------------------------------------------------------------
    dt = RangedFloat(1.0 / 120.0, 1e-4, 0.05, "s", help="Fixed simulation time step; step(n) advances n * dt.").tag(sync=True)

    # ---- culling and level of detail (per render, on the GPU) ------------------
    cull_orientation = CheckedBool(True, help="Cull blades seen edge-on.").tag(sync=True)
    cull_orientation_threshold = RangedFloat(0.9, 0.0, 1.0, help="Cull when |dot(view dir to v0, width dir)| exceeds this.").tag(sync=True)
    cull_frustum = CheckedBool(True, help="Cull blades whose v0, curve midpoint and v2 are all outside the view.").tag(sync=True)
    cull_frustum_tolerance = RangedFloat(0.5, 0.0, 10.0, help="Slack added to clip-space w in the frustum test (paper/author: 0.5).").tag(sync=True)
    cull_distance = CheckedBool(True, help="Thin the field with distance on the ground.").tag(sync=True)
    cull_distance_max = RangedFloat(100.0, 0.01, 1e6, "m", help="Ground distance at which every blade is culled.").tag(sync=True)
    cull_buckets = RangedInt(100, 1, 4096, help="Number of distance buckets n (paper/author: 100).").tag(sync=True)
    cull_occlusion = AutoSwitch("auto", help="Cull blades hidden behind nearer geometry (a max-depth pyramid of this frame's first draws, conservative: the picture is the one without it). True (on), False (off) or 'auto' (the default: each view, in either engine, measures whether it pays and decides, see grasswidget.core.auto_switches). Kernel engine; a plain renderer.render() without grasswidget.gpu.render_frame draws as if it were off.").tag(sync=True)
    lod = CheckedBool(True, help="Use fewer segments per blade where a blade covers few pixels.").tag(sync=True)
    compute_raster = AutoSwitch("auto", help="Draw thin blades (projected width under compute_raster_max_px) with a compute rasterizer (one thread per blade walks its curve once with a 64-bit atomic depth test where the device has 64-bit atomics, else twice with 32-bit ones; then a resolve over the rows written that writes colour and depth) instead of the hardware rasterizer, which is slowest exactly there. Same picture up to sub-pixel coverage. Both engines: the kernel's through grasswidget.gpu.render_frame (GrassScene and the widget use it), the browser engine's with the same WGSL. True (on), False (off) or 'auto' (the default: each view, in either engine, measures whether it pays and decides, see grasswidget.core.auto_switches). Slower on a CPU adapter (lavapipe: the cis565 view at 2^14 blades 1.8x the frame time; SwiftShader: the default view has no blade that thin, see benchmarks/README.md).").tag(sync=True)
    compute_raster_max_px = RangedFloat(2.0, 0.0, 16.0, "px", help="Blades narrower than this on screen (full width at the blade's middle, physical pixels) go to the compute rasterizer when compute_raster is on; 0 sends none. GrassScene's own params on a GPU adapter use 4 (measured on an H100: more frames, the same look).").tag(sync=True)

    # ---- teaching views -----------------------------------------------------------
    color_by = ChoiceTrait("natural", COLOR_BY, help='How blades are coloured: "natural" (lit grass), "lod" (every drawn blade flat in its level-of-detail class colour, grasswidget.LOD_COLORS) or "cull" (every blade drawn; culled ones flat in the colour of the first test that culled them, grasswidget.CULL_COLORS: orientation, frustum, distance, occlusion). Applies at the next render.').tag(sync=True)

    def copy(self) -> "GrassParams":
        """A new GrassParams with the same values."""
        return GrassParams(**self.values())

    def values(self) -> dict:
        """All trait values as a plain dict."""
        return {name: getattr(self, name) for name in self.trait_names()}

    def __repr__(self):
        items = ", ".join(f"{k}={v!r}" for k, v in self.values().items())
        return f"GrassParams({items})"
