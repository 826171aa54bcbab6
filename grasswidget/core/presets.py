"""What a view shows, in pure Python (no GPU import): named presets and view sizes.

``preset_field(name)`` gives the blades, default size and camera of a named
scene (``GrassScene.preset`` builds its GPU scene from it; the browser engine
sends the same blades and camera to the browser); ``parse_size`` reads a view
size and ``check_png_path`` a picture's file name (every ``save_png``).
``grasswidget.gpu.scene`` re-exports ``preset_field`` and ``parse_size``.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .blades import Blades
from ..errors import GrassTypeError, GrassValueError, MissingFileError

__all__ = ["PRESETS", "PRESET_PARAMS", "preset_field", "preset_params", "parse_size", "check_png_path"]

#: Named scenes: see GrassScene.preset().
PRESETS = ("cis565", "meadow")

#: The GrassParams values a preset sets when it makes its own params (``params=None``):
#: the cis565 preset's distance culling reaches zero at 40 m (``cull_distance_max``; the
#: paper's 100 m is for fields of hundreds of metres, this field's far corner is 18 m away).
PRESET_PARAMS = {"cis565": {"cull_distance_max": 40.0}, "meadow": {}}


def preset_params(name) -> dict:
    """The GrassParams values (trait -> value) preset ``name`` sets when it makes its own
    params; ``GrassScene.preset`` and ``GrassWidget(preset=...)`` both use them, so a widget
    and a scene of one preset cull alike."""
    if name not in PRESETS:
        raise GrassValueError(f"preset must be one of {', '.join(PRESETS)}; got {name!r}")
    return dict(PRESET_PARAMS[name])


def parse_size(size, name="size"):
    """(w, h) from a tuple or a "WxH" string; both within 1..16384 pixels."""
    if isinstance(size, str):
        parts = size.lower().split("x")
        try:
            size = tuple(int(p) for p in parts)
        except ValueError:
            size = None
    try:
        w, h = (int(size[0]), int(size[1]))
        ok = len(size) == 2 and all(float(s) == int(s) for s in size)
    except (TypeError, ValueError, IndexError):
        ok = False
    if not ok or not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise GrassValueError(f"{name} must be (width, height) in pixels, each 1..16384, e.g. (640, 480) or '640x480'; got {size!r}")
    return w, h


def check_png_path(path, name="path") -> str:
    """``path`` as a str if it names a PNG file in an existing folder: it must end in ``.png``
    (any case; the pictures are always written as PNG, so another extension would name the
    file falsely: GrassValueError) and its folder must exist (MissingFileError; nothing is
    created). ``name`` is the argument named in the message."""
    if not isinstance(path, (str, os.PathLike)):
        raise GrassTypeError(f"{name} must be a file name ending in .png, not {type(path).__name__}")
    path = os.fspath(path)
    if not isinstance(path, str) or os.path.splitext(path)[1].lower() != ".png":
        raise GrassValueError(f"{name} must end in .png (pictures are written as PNG); got {path!r}")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise MissingFileError(f"{name}: the folder {folder!r} does not exist")
    return path


#: The meadow preset's reach (about how far its last level of blades reaches from the camera, and how
#: far the camera may go from the middle) as a share of its camera's far plane: the ground fades into
#: the horizon from 0.6 of the far plane (sky_ground.wgsl), so every blade is drawn before that fade
#: starts, and beyond them the ground has the grass's colour.
MEADOW_REACH_OF_FAR = 0.5
#: The meadow's camera far plane (m).
MEADOW_FAR = 400.0


def meadow_side(count) -> float:
    """Side (m) of the meadow's square field of ``count`` blades (about 1000 per m^2, 15..250 m);
    with the horizon on, the square whose density level 0 keeps and the cameras frame."""
    return float(np.clip(math.sqrt(count / 1000.0), 15.0, 250.0))


def preset_field(name, blades=None, seed=0, horizon=True):
    """The blades, default size and camera of a named scene (see :meth:`GrassScene.preset`).

    ``horizon`` (the meadow only; default True): the meadow reaches the horizon
    (``Blades.on_plane(..., reach=...)``: levels of tiles that follow the camera, the nearest at
    the square field's density where the count allows, then thinner, wider blades out to about
    :data:`MEADOW_REACH_OF_FAR` of the far plane, and grass-coloured ground beyond); False: the
    square field of before.

    Returns ``(Blades, (w, h), view)`` with view a dict of position, target
    (metres), fov_deg (vertical), near, far. Pure: no GPU work (the browser
    engine builds its presets from it too).
    """
    if name not in PRESETS:
        raise GrassValueError(f"preset must be one of {', '.join(PRESETS)}; got {name!r}")
    if not isinstance(horizon, (bool, np.bool_)):
        raise GrassValueError(f"horizon must be True or False; got {horizon!r}")
    if name == "cis565":
        n = 1 << 13 if blades is None else blades
        b = Blades.on_plane(n, 15.0, seed=seed) if not isinstance(n, Blades) else n
        view = dict(position=(0, 1, 10), target=(0, 1, 0), fov_deg=45, near=0.1, far=100)
        return b, (640, 480), view
    n = 1 << 20 if blades is None else blades
    side = meadow_side(n if not isinstance(n, Blades) else len(n))
    if not isinstance(n, Blades):
        reach = MEADOW_REACH_OF_FAR * MEADOW_FAR if horizon else None
        n = Blades.on_plane(n, side, seed=seed, height=(0.5, 1.0), width=(0.02, 0.04), stiffness=(7.0, 13.0),
                            reach=reach)
    position, target = (0.0, 3.0, side / 2 + 2.0), (0.0, 0.0, side / 2 - 30.0)
    if getattr(n, "horizon", None) is not None and target[2] < -side / 2:
        # the same view, its target (the orbit's pivot) moved along the ray onto the near disc's edge
        s = (position[2] + side / 2) / (position[2] - target[2])
        target = (0.0, position[1] + s * (target[1] - position[1]), -side / 2)
    view = dict(position=position, target=target, fov_deg=50, near=0.1, far=MEADOW_FAR)
    return n, (1920, 1080), view
