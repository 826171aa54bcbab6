"""Which walk the kernel's compute rasterizer runs (raster.wgsl): one walk with 64-bit atomics,
or two walks with 32-bit ones.

One walk ("packed"): each pixel is a u64, the depth's float bits in the high word and the
bitwise complement of the payload (blade id and curve point) in the low word; one
``atomicMin`` per pixel keeps the nearest blade and its payload at once. It needs the
device features :data:`ONE_WALK_FEATURES` (lavapipe and most Vulkan GPUs have them;
:func:`grasswidget.gpu.adapter.ensure_device` asks for them where the adapter offers them).
Two walks ("depth", then "payload"): the depth first, then the payload of the blade whose
depth won; the browser engine always walks this way (WebGPU has no 64-bit atomics), so the
same pictures come from both (the same winner per pixel: the nearest depth, equal depths
the larger payload).

The choice is made here, in Python, per field when it is created
(:attr:`grasswidget.gpu.field.GrassField.raster_packed`) and reaches the WGSL as the template
variable ``raster_packed``.
"""

from __future__ import annotations

from ..errors import GrassValueError

__all__ = ["ONE_WALK_FEATURES", "SHADE_STEPS", "one_walk_supported", "prefer_two_walks", "two_walks_preferred", "raster_packed",
           "raster_walk_steps"]

#: The wgpu features the one-walk layout needs (u64 in WGSL and its atomicMin).
ONE_WALK_FEATURES = ("shader-int64", "shader-int64-atomic-min-max")
#: The raster.wgsl steps after the walks, in both layouts and both phases: one thread sizes the shade
#: ("shade_args"), then a thread per pixel of the written rows shades the winning blade ("shade").
SHADE_STEPS = ("shade_args", "shade")

_preference = {"two_walks": False}


def one_walk_supported(device) -> bool:
    """True when ``device`` (a wgpu device) has every feature of :data:`ONE_WALK_FEATURES`."""
    features = set(device.features)
    return all(name in features for name in ONE_WALK_FEATURES)


def prefer_two_walks(on: bool = True) -> None:
    """Make fields created from now on walk twice (the browser engine's layout) even where the
    device offers 64-bit atomics (``on`` False: back to one walk where it can). For tests and
    benchmarks that compare the two layouts; fields already created keep theirs."""
    if not isinstance(on, bool):
        raise GrassValueError(f"on must be True or False; got {on!r}")
    _preference["two_walks"] = on


def two_walks_preferred() -> bool:
    """True after :func:`prefer_two_walks` (True) until it is switched back."""
    return _preference["two_walks"]


def raster_packed(device) -> bool:
    """The layout for a field created now on ``device``: True (one walk) where the device
    supports it and two walks are not preferred."""
    return one_walk_supported(device) and not two_walks_preferred()


def raster_walk_steps(field) -> tuple:
    """The raster.wgsl walk steps of ``field`` (a GrassField), in order: ("packed",) (one walk)
    or ("depth", "payload") (two walks), by its :attr:`~grasswidget.gpu.field.GrassField.raster_packed`."""
    return ("packed",) if field.raster_packed else ("depth", "payload")
