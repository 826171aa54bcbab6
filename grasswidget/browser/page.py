"""A live page with no kernel: one self-contained HTML file that runs the browser engine.

:func:`page_html` writes the browser engine (its one module text, :func:`grasswidget.browser.esm.engine_module_text`), the synced
state of a :class:`~grasswidget.browser.engine_widget.BrowserEngineWidget` (every synced trait of
the engine; binary ones base64), a small page script (``page.js``: a model shim
with ``get/set/on/off/send/save_changes`` that answers the engine locally, and a
plain-HTML control panel) and an optional still picture (PNG) into one file.
Nothing is fetched from the network.

The page script knows no trait names. Python describes every control as
*patches of the synced state*, found by changing the parameter on a scratch
view and comparing its state before and after:

* a discrete control (play/pause, a culling switch, colour by, a wind slider on
  a grid of values, the ball on/off) carries, for each of its values, the bytes
  of the binary traits it touches (at the byte ranges where any of its values
  differs from the start) and the JSON traits it touches, whole;
* the ball's position is affine: each number it touches (a float32 inside a
  binary trait, or a number inside a JSON trait) is ``c + ax x + az z``, fitted
  on three probe positions and checked on a fourth.

So whatever traits the engine reads, the page sends what the kernel would have.
Footprints of different controls never overlap (checked when the page is built).

Pure Python: no GPU import. :mod:`grasswidget.tools.html_export` renders the still
picture in the kernel engine and writes the file.
"""

from __future__ import annotations

import base64
import json
import math
import re
from pathlib import Path

import numpy as np

from ..core.colliders import SphereCollider
from ..core.enums import ColorBy
from ..core.interaction import ball_reach, input_rules
from ..core.params import GrassParams
from ..errors import GrassTypeError, GrassValueError, MissingFileError, PageBuildError
from .esm import engine_module_text

__all__ = ["PAGE_MAX_BLADES", "PAGE_MAX_PIXELS", "check_page_path", "check_page_blades", "page_state",
           "page_controls", "page_html", "fill_template", "PageBuildError"]

HERE = Path(__file__).resolve().parent
#: Most blades a live page carries: 64 bytes each, base64 in the page (about 22 MB at the limit).
PAGE_MAX_BLADES = 1 << 18
#: Most pixels of the view (e.g. 1920 x 1080 fits).
PAGE_MAX_PIXELS = 2560 * 1600
#: Traits larger than this (bytes) are state, never control patches (the blades).
_PATCH_LIMIT = 65536
#: Wind strength slider: values on this many steps from 0 to its top (m/s^2).
WIND_STRENGTH_STEPS = 40
#: Wind direction slider step (degrees).
WIND_DIRECTION_STEP = 15


def check_page_path(path) -> Path:
    """``path`` as a Path if it names an .html file in an existing folder; else
    GrassValueError (the name) or MissingFileError (the folder)."""
    if not isinstance(path, (str, Path)):
        raise GrassTypeError(f"path must be a str or Path ending in .html; got {type(path).__name__}")
    p = Path(path)
    if p.suffix.lower() != ".html":
        raise GrassValueError(f"path must end in .html (one self-contained page); got {str(path)!r}")
    if p.is_dir():
        raise GrassValueError(f"path {str(path)!r} is a folder; give a file name ending in .html")
    folder = p.resolve().parent
    if not folder.is_dir():
        raise MissingFileError(f"the folder {str(folder)!r} does not exist; create it first (path {str(path)!r})")
    return p


def check_page_blades(n: int) -> int:
    """``n`` if a page may carry that many blades (1 ..:data:`PAGE_MAX_BLADES`), else GrassValueError."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= int(n) <= PAGE_MAX_BLADES:
        raise GrassValueError(
            f"blades: a live page carries at most {PAGE_MAX_BLADES} blades ({PAGE_MAX_BLADES * 64 * 4 // 3 >> 20} MB "
            f"of base64 in the file); got {n!r}. Use fewer blades, or the notebook widget for more.")
    return int(n)


def _check_size(size):
    w, h = int(size[0]), int(size[1])
    if w < 16 or h < 16 or w * h > PAGE_MAX_PIXELS:
        raise GrassValueError(f"size: the page's view must be at least 16 x 16 and at most {PAGE_MAX_PIXELS} "
                              f"pixels (e.g. 2560 x 1600); got {w} x {h}")
    return w, h


# ---------------------------------------------------------------------- state


def _engine_keys(view) -> list:
    """The view's own synced traits (those of the engine, not of anywidget/ipywidgets)."""
    import anywidget

    base = set(anywidget.AnyWidget.class_trait_names(sync=True))
    return sorted(k for k in view.trait_names(sync=True) if k not in base)


def page_state(view) -> dict:
    """{"state": {trait: value}, "binary": [names of base64 values]} of every synced engine trait."""
    state, binary = {}, []
    for k in _engine_keys(view):
        v = getattr(view, k)
        if isinstance(v, (bytes, bytearray, memoryview)):
            state[k] = base64.b64encode(bytes(v)).decode("ascii")
            binary.append(k)
        else:
            state[k] = _jsonable(v)
    return {"state": state, "binary": binary}


def _jsonable(v):
    return json.loads(json.dumps(v, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))


class _Recorder:
    """Snapshots of a scratch view's small synced traits."""

    def __init__(self, view):
        self.view = view
        self.keys = [k for k in _engine_keys(view) if _size_of(getattr(view, k)) <= _PATCH_LIMIT]

    def snap(self) -> dict:
        return {k: _plain(getattr(self.view, k)) for k in self.keys}


def _size_of(v) -> int:
    if isinstance(v, (bytes, bytearray, memoryview)):
        return len(bytes(v))
    return len(json.dumps(_jsonable(v)))


def _plain(v):
    if isinstance(v, (bytes, bytearray, memoryview)):
        return bytes(v)
    return _jsonable(v)


def _b64(b: bytes) -> str:
    return base64.b64encode(b).decode("ascii")


def _runs(mask: np.ndarray) -> list:
    """[[start, end), ...] of the True runs of a boolean array."""
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [[int(a), int(b)] for a, b in zip(idx[::2], idx[1::2])]


def _discrete(rec, base, values, apply, restore):
    """Footprint and patches of one control: for each value, what the state becomes."""
    snaps = []
    for v in values:
        apply(v)
        snaps.append(rec.snap())
    restore()
    if rec.snap() != base:
        raise PageBuildError("a control did not restore the state it started from")
    footprint_bin, footprint_json = {}, []
    for k, b in base.items():
        if isinstance(b, bytes):
            mask = np.zeros(len(b), bool)
            for s in snaps:
                if len(s[k]) != len(b):
                    raise PageBuildError(f"trait {k} changed length")
                mask |= np.frombuffer(s[k], np.uint8) != np.frombuffer(b, np.uint8)
            if mask.any():
                footprint_bin[k] = _runs(mask)
        elif any(s[k] != b for s in snaps):
            footprint_json.append(k)
    patches = []
    for s in snaps:
        patches.append({
            "bin": {k: _b64(b"".join(s[k][a:e] for a, e in runs)) for k, runs in footprint_bin.items()},
            "json": {k: s[k] for k in footprint_json},
        })
    return {"footprint": {"bin": footprint_bin, "json": footprint_json}, "patches": patches}


def _leaves(v, path=()):
    if isinstance(v, bool):
        return
    if isinstance(v, (int, float)):
        yield path, float(v)
    elif isinstance(v, list):
        for i, x in enumerate(v):
            yield from _leaves(x, path + (i,))
    elif isinstance(v, dict):
        for k, x in v.items():
            yield from _leaves(x, path + (k,))


def _affine(rec, place, x0, z0, step):
    """Slots of state that follow the ball's (x, z): {bin: [[trait, offset, c, ax, az]], json: [[trait, path, c, ax, az]]}."""
    probes = [(x0, z0), (x0 + step, z0), (x0, z0 + step), (x0 + step, z0 + step)]
    snaps = []
    for x, z in probes:
        place(x, z)
        snaps.append(rec.snap())
    place(x0, z0)
    out = {"bin": [], "json": []}

    def fit(values, where):
        c, ax, az = values[0], (values[1] - values[0]) / step, (values[2] - values[0]) / step
        predicted = c + ax * step + az * step
        if abs(predicted - values[3]) > 1e-4 * max(1.0, abs(values[3])):
            raise PageBuildError(f"the ball's position does not map affinely onto {where}")
        return [c - ax * x0 - az * z0, ax, az]  # intercept at x = z = 0

    for k, b in snaps[0].items():
        if isinstance(b, bytes):
            arrs = [np.frombuffer(s[k][: len(b) // 4 * 4], "<f4").astype(np.float64) for s in snaps]
            changed = np.flatnonzero(np.any([a != arrs[0] for a in arrs[1:]], axis=0))
            for i in changed:
                out["bin"].append([k, int(4 * i), *fit([a[i] for a in arrs], f"{k}[{4 * i}]")])
        else:
            leaves = [dict(_leaves(s[k])) for s in snaps]
            for path, v in leaves[0].items():
                vals = [lv.get(path) for lv in leaves]
                if None in vals:
                    raise PageBuildError(f"the ball's position changes the shape of {k}")
                if any(x != vals[0] for x in vals[1:]):
                    out["json"].append([k, list(path), *fit(vals, f"{k}{list(path)}")])
    return out


def _overlap_check(controls):
    seen_bin, seen_json = {}, {}
    for c in controls:
        fp = c.get("footprint")
        if fp is None:
            continue
        for k in fp["json"]:
            if k in seen_json:
                raise PageBuildError(f"controls {seen_json[k]!r} and {c['id']!r} both change {k}")
            seen_json[k] = c["id"]
        for k, runs in fp["bin"].items():
            mask = seen_bin.setdefault(k, {})
            for a, e in runs:
                for i in range(a, e):
                    if i in mask:
                        raise PageBuildError(f"controls {mask[i]!r} and {c['id']!r} both change byte {i} of {k}")
                    mask[i] = c["id"]


def _nearest(values, v):
    return int(np.argmin([abs(x - v) for x in values]))


def page_controls(view, ball_radius=None, ball_enabled=False) -> dict:
    """The control panel of the page, described as state patches (see the module docstring).

    ``view`` is a scratch :class:`BrowserEngineWidget` (its params and colliders are changed
    and put back; give one nobody shows). ``ball_radius`` (metres; default a tenth of
    the field's extent, at least 0.1), ``ball_enabled``: the ball shown at the start.
    """
    p: GrassParams = view.params
    rec = _Recorder(view)
    start_colliders = list(view.colliders)
    base = rec.snap()
    controls = []

    def param_control(cid, label, kind, name, values, labels=None, **extra):
        current = getattr(p, name)

        def apply(v):
            setattr(p, name, v)

        def restore():
            setattr(p, name, current)

        c = _discrete(rec, base, values, apply, restore)
        idx = values.index(current) if current in values else _nearest(values, current)
        controls.append(dict(c, id=cid, label=label, kind=kind, values=_jsonable(list(values)),
                             labels=labels, value=idx, **extra))

    # play / pause: the view's own playing
    playing = bool(view.playing)

    def set_playing(v):
        view.playing = v

    c = _discrete(rec, base, [True, False], set_playing, lambda: set_playing(playing))
    controls.append(dict(c, id="playing", label="play", kind="play", values=[True, False], labels=["Pause", "Play"],
                         value=0 if playing else 1))

    top = float(min(200.0, max(20.0, 2.0 * p.wind_strength)))
    strengths = sorted({round(top * k / WIND_STRENGTH_STEPS, 3) for k in range(WIND_STRENGTH_STEPS + 1)}
                       | {float(p.wind_strength)})
    param_control("wind_strength", "wind strength (m/s²)", "slider", "wind_strength", strengths)
    directions = sorted({float(d) for d in range(0, 360, WIND_DIRECTION_STEP)} | {float(p.wind_direction)})
    param_control("wind_direction", "wind direction (°)", "slider", "wind_direction", directions)
    fields = ["wave", "radial", "vortex", "noise"] + (["custom"] if p.wind_wgsl else [])
    if p.wind_field not in fields:
        fields.append(p.wind_field)
    param_control("wind_field", "wind field", "select", "wind_field", fields)
    for cid, label in (("cull_orientation", "orientation culling"), ("cull_frustum", "frustum culling"),
                       ("cull_distance", "distance culling"), ("lod", "LOD")):
        param_control(cid, label, "checkbox", cid, [False, True])
    # a three-way switch (core.auto_switches.AutoSwitch): "auto" is the browser engine's own choice
    param_control("cull_occlusion", "occlusion culling", "select", "cull_occlusion", ["auto", True, False],
                  labels=["auto", "on", "off"])
    colour = [label for label in ColorBy.labels()]
    param_control("color_by", "colour by", "select", "color_by", colour)

    # the ball: on/off (discrete), then its position (affine, while on)
    blades = view.blades
    lo, hi = blades.v0.min(axis=0), blades.v0.max(axis=0)
    extent = float(max(hi[0] - lo[0], hi[2] - lo[2], 1.0))
    radius = float(ball_radius) if ball_radius is not None else round(max(0.1, 0.1 * extent), 2)
    if not (radius > 0 and math.isfinite(radius)):
        raise GrassValueError(f"ball_radius must be a positive number of metres; got {ball_radius!r}")
    ground = float(lo[1])
    x0, z0 = float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[2] + hi[2]))
    if ball_enabled and start_colliders:
        x0, z0 = float(start_colliders[0].center[0]), float(start_colliders[0].center[2])

    def place(x, z):
        view.colliders = [SphereCollider(center=(x, ground + radius, z), radius=radius)]

    def set_ball(on):
        if on:
            place(x0, z0)
        else:
            view.colliders = []

    def restore_colliders():
        view.colliders = start_colliders

    c = _discrete(rec, base, [False, True], set_ball, restore_colliders)
    place(x0, z0)
    slots = _affine(rec, place, x0, z0, step=max(0.25, 0.05 * extent))
    restore_colliders()
    if rec.snap() != base:
        raise PageBuildError("the ball control did not restore the state it started from")
    controls.append(dict(c, id="ball", label="ball (shift + drag to move it)", kind="ball", values=[False, True],
                         value=1 if ball_enabled else 0, slots=slots, position=[x0, z0],
                         reach=[float(v) for v in ball_reach(lo, hi)]))
    _overlap_check(controls)
    # the home view: the camera as it is now ("reset view" and the r key)
    home = {"json": {k: v for k, v in base.items() if k == _camera_trait(view)}}
    return {"controls": controls, "home": home}


def _camera_trait(view) -> str:
    """The name of the view's camera trait (Python knows it; the page does not)."""
    return "camera" if "camera" in view.trait_names(sync=True) else ""


def page_html(view, *, title="grasswidget meadow", still_png: bytes | None = None, ball_radius=None,
              ball_enabled=False, note="") -> str:
    """The whole page as text (see the module docstring); ``view`` as in :func:`page_controls`."""
    check_page_blades(len(view.blades))
    _check_size((view.width, view.height))
    data = {
        "engine": engine_module_text(),
        **page_state(view),
        **page_controls(view, ball_radius=ball_radius, ball_enabled=ball_enabled),
        "input": input_rules(),  # the keys' actions (as a view's, core.interaction.key_action)
        "still": _b64(still_png) if still_png else None,
        "size": [int(view.width), int(view.height)],
        "blades": len(view.blades),
        "title": title,
        "note": note,
    }
    payload = json.dumps(data, separators=(",", ":"))
    # Inside <script>: no "</" may close it early, and U+2028/9 are fine in JSON but not older JS.
    payload = (payload.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
               .replace("\u2028", "\\u2028").replace("\u2029", "\\u2029"))
    template = (HERE / "page.html").read_text(encoding="utf-8")
    script = (HERE / "page.js").read_text(encoding="utf-8")
    if "</script" in script.lower():
        raise PageBuildError("page.js must not contain </script>")
    import html

    return fill_template(template, {"TITLE": html.escape(title), "DATA": payload, "SCRIPT": script})


def fill_template(template: str, values: dict) -> str:
    """``template`` with each ``{{NAME}}`` slot replaced by ``values[NAME]``, in one pass.

    Each slot must appear exactly once (PageBuildError otherwise: a broken template is a
    bug). The inserted texts are never scanned again, so a user's text that itself reads
    ``{{SCRIPT}}`` (a title, a wind WGSL in the data block) stays what it was and cannot
    change the page's structure."""
    slots = re.findall(r"\{\{([A-Z_]+)\}\}", template)
    if sorted(slots) != sorted(values):
        raise PageBuildError(f"the page template's slots are {sorted(slots)}, expected each of {sorted(values)} once")
    return re.sub(r"\{\{([A-Z_]+)\}\}", lambda m: values[m.group(1)], template)
