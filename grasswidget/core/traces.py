"""Traces: what the simulation did over simulated time, for a lab bench (pure NumPy).

A :class:`TraceRecorder` keeps one :class:`TraceSample` per sample the view
takes while simulated time advances (the views' sampling rule: see
:mod:`grasswidget.views.trace_feed`) and turns them into NumPy arrays
(:meth:`TraceRecorder.traces`), into the series a chart draws
(:meth:`TraceRecorder.chart_series`) and into a file (:meth:`TraceRecorder.save`,
CSV or .npz; :func:`load_traces` reads either back).

Per sample: simulated time ``t`` (s since ``reset_blades()``) and the step count;
for every inspected blade its id, root ``v0``, tip guide ``v2`` (field-local
metres), ``up``, height, collision strength (the blade's stored collision factor
eta, 0..1) and the force vectors of ``reference.FORCE_NAMES`` (gravity, recovery,
wind in m/s^2, collision: the push of one step in m); for the whole field the
blades kept after each culling test of :data:`CULL_TESTS` and drawn by each path
of :data:`DRAW_PATHS`; and where a frame's time went (:data:`FRAME_STAGES`, ms).
Numbers a view does not know are NaN.

A rolling window (``window_s``, default :data:`DEFAULT_WINDOW_S` simulated seconds)
bounds memory: samples older than the newest minus the window are dropped, and at
most :data:`MAX_SAMPLES` are kept whatever the window. Simulated time going back
(``reset_blades()``) starts a new trace.
"""

from __future__ import annotations

import collections
import csv
import math
import os
import zipfile
from dataclasses import dataclass, field

import numpy as np

from ..errors import GrassTypeError, GrassValueError, MissingFileError, TraceFileError
from .reference import FORCE_NAMES

__all__ = ["TraceSample", "TraceRecorder", "load_traces", "check_window", "check_trace_path", "CULL_TESTS",
           "DRAW_PATHS", "FRAME_STAGES", "DEFAULT_WINDOW_S", "WINDOW_RANGE_S", "MAX_SAMPLES", "TRACE_FORMATS",
           "CHART_KINDS", "tip_offset", "bend_degrees"]

#: The culling tests, in the order they run; ``kept[test]`` counts the blades that pass it and every test before it.
CULL_TESTS = ("orientation", "frustum", "distance", "occlusion")
#: The two drawing paths: hardware ribbons and the compute rasterizer (GrassParams.compute_raster).
DRAW_PATHS = ("ribbons", "compute")
#: Where a frame's time goes (ms), as the stats line's details name it.
FRAME_STAGES = ("render", "readback", "encode_send", "ack")
#: Default rolling window, simulated seconds.
DEFAULT_WINDOW_S = 60.0
#: The window a recorder accepts, simulated seconds (inclusive).
WINDOW_RANGE_S = (0.1, 3600.0)
#: At most this many samples are kept, whatever the window (about 100 MB with 64 blades inspected).
MAX_SAMPLES = 200_000
#: The file formats :meth:`TraceRecorder.save` writes, by extension.
TRACE_FORMATS = (".csv", ".npz")
#: What a chart can show (None: hidden).
CHART_KINDS = ("tip", "bend", "culling", "frame")


def check_window(window_s, name="window_s") -> float:
    """A valid rolling window (simulated seconds) as a float; GrassValueError names ``name`` and the range."""
    lo, hi = WINDOW_RANGE_S
    if isinstance(window_s, bool) or not isinstance(window_s, (int, float, np.integer, np.floating)) \
            or not np.isfinite(window_s) or not lo <= float(window_s) <= hi:
        raise GrassValueError(f"{name} (rolling window of the traces, simulated seconds) must be a number "
                              f"in [{lo:g}, {hi:g}]; got {window_s!r}")
    return float(window_s)


def check_trace_path(path, must_exist=False) -> str:
    """A path ending in .csv or .npz whose folder exists; GrassValueError / MissingFileError otherwise."""
    if not isinstance(path, (str, os.PathLike)):
        raise GrassTypeError(f"path must be a file name ending in .csv or .npz, not {type(path).__name__}")
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in TRACE_FORMATS:
        raise GrassValueError(f"path must end in .csv or .npz (the traces' formats); got {path!r}")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise MissingFileError(f"path: the folder {folder!r} does not exist")
    if must_exist and not os.path.isfile(path):
        raise MissingFileError(f"path: no traces file {path!r}")
    return path


def tip_offset(v0, v2, up, height) -> np.ndarray:
    """Distance (m) of the tip guide ``v2`` from its rest position ``v0 + up * height``; (..., 3) -> (...)."""
    rest = np.asarray(v0) + np.asarray(up) * np.asarray(height)[..., None]
    return np.linalg.norm(np.asarray(v2) - rest, axis=-1)


def bend_degrees(v0, v2, up) -> np.ndarray:
    """Angle (degrees, 0..180) between the blade's root-to-tip-guide direction ``v2 - v0`` and ``up``."""
    d = np.asarray(v2, np.float64) - np.asarray(v0, np.float64)
    u = np.asarray(up, np.float64)
    cos = np.sum(d * u, axis=-1) / np.maximum(np.linalg.norm(d, axis=-1) * np.linalg.norm(u, axis=-1), 1e-30)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


@dataclass
class TraceSample:
    """One sample (see the module docstring). Arrays are per inspected blade, in ``ids`` order."""

    t: float
    step_count: int
    ids: tuple = ()
    v0: np.ndarray = None          # (K, 3) m, field-local
    v2: np.ndarray = None          # (K, 3) m, field-local
    up: np.ndarray = None          # (K, 3) unit
    height: np.ndarray = None      # (K,) m
    collision: np.ndarray = None   # (K,) eta, 0..1
    forces: np.ndarray = None      # (K, len(FORCE_NAMES), 3)
    kept: dict = field(default_factory=dict)      # CULL_TESTS -> count (None: unknown)
    drawn: dict = field(default_factory=dict)     # DRAW_PATHS -> count
    frame_ms: dict = field(default_factory=dict)  # FRAME_STAGES -> ms
    _tip_cm: list = field(default=None, repr=False, compare=False)
    _bend_deg: list = field(default=None, repr=False, compare=False)

    def tip_cm(self) -> list:
        """Tip offset from rest of each blade, cm (computed once, kept for the charts)."""
        if self._tip_cm is None:
            self._tip_cm = (100.0 * tip_offset(self.v0, self.v2, self.up, self.height)).tolist() if self.ids else []
        return self._tip_cm

    def bend_deg(self) -> list:
        """Bend angle from ``up`` of each blade, degrees (computed once)."""
        if self._bend_deg is None:
            self._bend_deg = bend_degrees(self.v0, self.v2, self.up).tolist() if self.ids else []
        return self._bend_deg

    @classmethod
    def from_inspected(cls, t, step_count, rows, up, kept=None, drawn=None, frame_ms=None):
        """A sample from ``read_inspected()``-style rows (dicts with id, height, v0, v2, the forces and
        ``collision_strength``), ``up`` the field's (N, 3) up vectors (indexed by id)."""
        ids = tuple(int(r["id"]) for r in rows)
        k = len(ids)
        f = np.zeros((k, len(FORCE_NAMES), 3), np.float64)
        for j, r in enumerate(rows):
            for m, name in enumerate(FORCE_NAMES):
                f[j, m] = r[name]
        return cls(t=float(t), step_count=int(step_count), ids=ids,
                   v0=np.array([r["v0"] for r in rows], np.float64).reshape(k, 3),
                   v2=np.array([r["v2"] for r in rows], np.float64).reshape(k, 3),
                   up=np.asarray(up, np.float64)[list(ids)].reshape(k, 3),
                   height=np.array([r["height"] for r in rows], np.float64),
                   collision=np.array([r.get("collision_strength", np.nan) for r in rows], np.float64),
                   forces=f, kept=dict(kept or {}), drawn=dict(drawn or {}), frame_ms=dict(frame_ms or {}))


def _number(x):
    return np.nan if x is None else float(x)


class TraceRecorder:
    """Samples over a rolling window of simulated time (see the module docstring).

    Args:
        window_s: keep the last this many simulated seconds (default 60; 0.1..3600).

    ``version`` counts the samples ever recorded (a chart redraws when it changes).
    """

    def __init__(self, window_s: float = DEFAULT_WINDOW_S):
        self._window = check_window(window_s)
        self._samples = collections.deque()
        self.version = 0

    @property
    def window_s(self) -> float:
        """Rolling window, simulated seconds (0.1..3600; GrassValueError names the range)."""
        return self._window

    @window_s.setter
    def window_s(self, value):
        self._window = check_window(value)
        self._trim()

    def __len__(self):
        return len(self._samples)

    def clear(self):
        """Forget every sample."""
        self._samples.clear()
        self.version += 1

    def record(self, sample: TraceSample):
        """Add a sample. One at the same step count as the newest replaces it (a frame redrawn
        without time passing); simulated time going back starts a new trace."""
        if self._samples:
            last = self._samples[-1]
            if sample.step_count < last.step_count or sample.t < last.t:
                self._samples.clear()
            elif sample.step_count == last.step_count:
                self._samples.pop()
        self._samples.append(sample)
        self.version += 1
        self._trim()

    def _trim(self):
        s = self._samples
        if not s:
            return
        oldest = s[-1].t - self._window
        while s and (s[0].t < oldest - 1e-9 or len(s) > MAX_SAMPLES):
            s.popleft()

    @property
    def last(self) -> TraceSample | None:
        """The newest sample, or None."""
        return self._samples[-1] if self._samples else None

    # ------------------------------------------------------------------ arrays

    def traces(self) -> dict:
        """The samples as NumPy arrays (T samples, K blades inspected at any time in the window,
        in the order they were first inspected; NaN where a blade was not inspected):

        ``t`` (T,) simulated s since reset_blades(); ``step`` (T,) int64 step count; ``ids`` (K,)
        int64; ``v0`` (T, K, 3), ``v2`` (T, K, 3) m in the field's local space; ``tip_offset``
        (T, K) m from rest; ``bend_deg`` (T, K) degrees from ``up``; ``collision`` (T, K) eta (0..1);
        ``force`` dict of (T, K) magnitudes per name of FORCE_NAMES (m/s^2; collision: m per
        step); ``kept`` dict of (T,) per CULL_TESTS; ``drawn`` dict of (T,) per DRAW_PATHS;
        ``frame_ms`` dict of (T,) per FRAME_STAGES; ``window_s`` (float).
        """
        return self._arrays(list(self._samples))

    def _arrays(self, samples) -> dict:
        n = len(samples)
        ids = []
        for s in samples:
            for i in s.ids:
                if i not in ids:
                    ids.append(i)
        col = {i: k for k, i in enumerate(ids)}
        k = len(ids)
        v0 = np.full((n, k, 3), np.nan)
        v2 = np.full((n, k, 3), np.nan)
        up = np.full((n, k, 3), np.nan)
        height = np.full((n, k), np.nan)
        collision = np.full((n, k), np.nan)
        forces = np.full((n, k, len(FORCE_NAMES)), np.nan)
        for r, s in enumerate(samples):
            if not s.ids:
                continue
            cols = [col[i] for i in s.ids]
            v0[r, cols], v2[r, cols], up[r, cols] = s.v0, s.v2, s.up
            height[r, cols], collision[r, cols] = s.height, s.collision
            forces[r, cols] = np.linalg.norm(np.asarray(s.forces, np.float64), axis=-1)
        return {
            "t": np.array([s.t for s in samples], np.float64),
            "step": np.array([s.step_count for s in samples], np.int64),
            "ids": np.array(ids, np.int64),
            "v0": v0,
            "v2": v2,
            "tip_offset": tip_offset(v0, v2, up, height),
            "bend_deg": bend_degrees(v0, v2, up),
            "collision": collision,
            "force": {name: forces[:, :, m] for m, name in enumerate(FORCE_NAMES)},
            "kept": {name: np.array([_number(s.kept.get(name)) for s in samples]) for name in CULL_TESTS},
            "drawn": {name: np.array([_number(s.drawn.get(name)) for s in samples]) for name in DRAW_PATHS},
            "frame_ms": {name: np.array([_number(s.frame_ms.get(name)) for s in samples]) for name in FRAME_STAGES},
            "window_s": self._window,
        }

    # ------------------------------------------------------------------ files

    def save(self, path) -> str:
        """Write the traces to ``path``: ``.npz`` (the arrays of :meth:`traces`, dicts flattened to
        ``kept_orientation`` etc.) or ``.csv`` (one row per sample: t, step, then per blade id
        ``v0x_<id>`` .. ``v0z_<id>``, ``v2x_<id>`` .. ``v2z_<id>``, ``tip_offset_<id>``, ``bend_deg_<id>``,
        ``collision_strength_<id>`` and ``force_<name>_<id>``, then ``kept_<test>``, ``drawn_<path>``,
        ``frame_ms_<stage>`` and ``window_s``, the same in every row). Returns the path.
        :func:`load_traces` reads either back, every field of :meth:`traces`."""
        path = check_trace_path(path)
        tr = self.traces()
        flat = _flatten(tr)
        if path.lower().endswith(".npz"):
            np.savez_compressed(path, **flat)
            return path
        header, columns = ["t", "step"], [tr["t"], tr["step"]]
        for j, i in enumerate(tr["ids"]):
            for a, axis in enumerate("xyz"):
                header.append(f"v0{axis}_{i}")
                columns.append(tr["v0"][:, j, a])
            for a, axis in enumerate("xyz"):
                header.append(f"v2{axis}_{i}")
                columns.append(tr["v2"][:, j, a])
            for name, column in _CSV_PER_BLADE:
                header.append(f"{column}_{i}")
                columns.append(tr[name][:, j])
            for name in FORCE_NAMES:
                header.append(f"force_{name}_{i}")
                columns.append(tr["force"][name][:, j])
        for group in ("kept", "drawn", "frame_ms"):
            for name, values in tr[group].items():
                header.append(f"{group}_{name}")
                columns.append(values)
        header.append("window_s")  # the same in every row: the recorder's window when saved
        columns.append(np.full(len(tr["t"]), tr["window_s"]))
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(header)
            for r in range(len(tr["t"])):
                w.writerow([_csv_cell(c[r]) for c in columns])
        return path

    # ------------------------------------------------------------------ charts

    def chart_series(self, kind: str, colors, max_points: int = 600) -> dict:
        """What a chart of ``kind`` (one of :data:`CHART_KINDS`) draws: ``{"x": [...], "x_label",
        "y_label", "y_zero" (the y axis starts at 0), "series": [{"label", "color", "values", "fill"}]}``
        as plain lists (NaN as None),
        at most ``max_points`` points (every k-th sample counted back from the newest). ``colors``: the
        colour of each inspected blade, by position in the ids (cycled)."""
        samples = list(self._samples)
        n = len(samples)
        if n > max_points:  # thin before building the arrays: a push costs the same however long the window
            stride = int(np.ceil(n / max_points))
            samples = [samples[i] for i in range(n - 1, -1, -stride)][::-1]
        # Plain Python over at most max_points samples (no (T, K, 3) arrays): a push costs about a
        # millisecond whatever the window holds.
        n = len(samples)
        series = []
        if kind in ("tip", "bend"):
            columns = {}
            for r, sample in enumerate(samples):
                per_blade = sample.tip_cm() if kind == "tip" else sample.bend_deg()
                for j, i in enumerate(sample.ids):
                    if i not in columns:
                        columns[i] = [None] * n
                    columns[i][r] = per_blade[j]
            # A blade inspected now has the colour of its place in the inspected ids (as the panel
            # shows it); one no longer inspected the next colours after those.
            now = list(self.last.ids) if self.last is not None else []
            extra = 0
            for i, values in columns.items():
                if i in now:
                    place = now.index(i)
                else:
                    place = len(now) + extra
                    extra += 1
                series.append({"label": f"blade {int(i)}", "color": colors[place % len(colors)], "values": values})
            y_label = "tip offset (cm)" if kind == "tip" else "bend from up (°)"
        elif kind == "culling":
            from .teaching import CULL_COLORS

            for name in CULL_TESTS:
                series.append({"label": f"kept after {name}", "color": CULL_COLORS[name],
                               "values": [s.kept.get(name) for s in samples], "fill": True})
            y_label = "blades kept"
        elif kind == "frame":
            for name, color in zip(FRAME_STAGES, ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728")):
                series.append({"label": name.replace("_", " + ") + " (ms)", "color": color,
                               "values": [s.frame_ms.get(name) for s in samples]})
            y_label = "ms per frame"
        else:
            raise GrassValueError(f"chart must be None or one of {', '.join(map(repr, CHART_KINDS))}; got {kind!r}")
        for s in series:
            s["values"] = [None if v is None or not math.isfinite(v) else float(v) for v in s["values"]]
            s.setdefault("fill", False)
        return {"x": [s.t for s in samples], "x_label": "simulated time (s)", "y_label": y_label, "y_zero": True,
                "series": series}


#: The per-blade arrays of :meth:`TraceRecorder.traces` and their CSV column names (``<name>_<id>``).
_CSV_PER_BLADE = (("tip_offset", "tip_offset"), ("bend_deg", "bend_deg"), ("collision", "collision_strength"))


def _csv_cell(x):
    x = float(x)
    return "" if not np.isfinite(x) else repr(x)


def _flatten(tr: dict) -> dict:
    out = {}
    for key, value in tr.items():
        if isinstance(value, dict):
            for name, arr in value.items():
                out[f"{key}_{name}"] = np.asarray(arr)
        else:
            out[key] = np.asarray(value)
    return out


def load_traces(path) -> dict:
    """Read a file :meth:`TraceRecorder.save` wrote (.npz or .csv) back into :meth:`TraceRecorder.traces`'s
    dict, every field: ``t``, ``step``, ``ids``, ``v0``, ``v2``, ``tip_offset``, ``bend_deg``, ``collision``,
    ``force``, ``kept``, ``drawn``, ``frame_ms`` and ``window_s`` (a CSV with no samples has no row to keep
    the window in: NaN). A file that is empty, truncated, not text or not written by ``save`` raises
    :class:`~grasswidget.errors.TraceFileError` naming the file and what is wrong with it."""
    path = check_trace_path(path, must_exist=True)
    try:
        if path.lower().endswith(".npz"):
            return _load_npz(path)
        return _load_csv(path)
    except TraceFileError:
        raise
    except (OSError, ValueError, KeyError, IndexError, EOFError, UnicodeDecodeError, zipfile.BadZipFile) as err:
        raise TraceFileError(f"{path!r} is not a traces file that save_traces wrote ({type(err).__name__}: {err})") \
            from None


_GROUPS = {"kept": CULL_TESTS, "drawn": DRAW_PATHS, "frame_ms": FRAME_STAGES, "force": FORCE_NAMES}


def _bad(path, what):
    return TraceFileError(f"{path!r} is not a traces file that save_traces wrote: {what}")


def _load_npz(path) -> dict:
    if os.path.getsize(path) == 0:
        raise _bad(path, "the file is empty")
    try:
        with np.load(path, allow_pickle=False) as z:
            flat = {k: z[k] for k in z.files}
    except ValueError as err:
        if "pickle" not in str(err).lower():
            raise
        # NumPy's own text suggests loading it "unsafely": load_traces never does (a traces file has
        # no Python objects; unpickling runs code from the file).
        raise _bad(path, "it holds pickled Python objects, which are never loaded (save_traces writes "
                         "numbers only)") from None
    missing = [k for k in ("t", "step", "ids", "v0", "v2", "window_s") if k not in flat]
    if missing:
        raise _bad(path, f"no {', '.join(missing)} in it")
    n, k = len(flat["t"]), len(flat["ids"])
    for name in ("v0", "v2"):
        if flat[name].shape != (n, k, 3):
            raise _bad(path, f"{name} has shape {flat[name].shape}, expected {(n, k, 3)} (samples, blades, 3)")
    out = {k: v for k, v in flat.items() if not any(k.startswith(g + "_") and k[len(g) + 1:] in names
                                                  for g, names in _GROUPS.items())}
    for g, names in _GROUPS.items():
        out[g] = {name: flat[f"{g}_{name}"] for name in names if f"{g}_{name}" in flat}
    out["window_s"] = float(out["window_s"])
    return out


def _load_csv(path) -> dict:
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise _bad(path, "the file is empty")
    header, body = rows[0], rows[1:]
    for name in ("t", "step"):
        if name not in header:
            raise _bad(path, f"no {name!r} column in its first row")
    if len(set(header)) != len(header):
        raise _bad(path, "a column name appears twice in its first row")
    for r, row in enumerate(body, start=2):
        if len(row) != len(header):
            raise _bad(path, f"line {r} has {len(row)} cells where the first row names {len(header)} "
                             "(truncated or edited?)")
    data = np.full((len(body), len(header)), np.nan)
    for r, row in enumerate(body):
        for j, cell in enumerate(row):
            if cell:
                try:
                    data[r, j] = float(cell)
                except ValueError:
                    raise _bad(path, f"line {r + 2}, column {header[j]!r}: {cell[:40]!r} is not a number") from None
    col = {name: data[:, j] for j, name in enumerate(header)}
    ids = [int(name[4:]) for name in header if name.startswith("v2x_") and name[4:].isdigit()]
    per_blade = [f"{v}{a}_{i}" for i in ids for v in ("v0", "v2") for a in "xyz"]
    per_blade += [f"{column}_{i}" for i in ids for _, column in _CSV_PER_BLADE]
    per_blade += [f"force_{name}_{i}" for i in ids for name in FORCE_NAMES]
    whole = [f"{g}_{name}" for g in ("kept", "drawn", "frame_ms") for name in _GROUPS[g]]
    missing = [name for name in per_blade + whole if name not in col]
    if missing:
        raise _bad(path, f"no column {missing[0]!r}" + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""))
    if not np.all(np.isfinite(col["t"])) or not np.all(np.isfinite(col["step"])):
        raise _bad(path, "a row without its simulated time t or step")
    out = {"t": col["t"], "step": col["step"].astype(np.int64), "ids": np.array(ids, np.int64)}
    for v in ("v0", "v2"):
        out[v] = np.stack([np.stack([col[f"{v}{a}_{i}"] for a in "xyz"], axis=-1) for i in ids], axis=1) \
            if ids else np.zeros((len(body), 0, 3))
    for name, column in _CSV_PER_BLADE:
        out[name] = np.stack([col[f"{column}_{i}"] for i in ids], axis=1) if ids else np.zeros((len(body), 0))
    out["force"] = {name: (np.stack([col[f"force_{name}_{i}"] for i in ids], axis=1) if ids
                           else np.zeros((len(body), 0))) for name in FORCE_NAMES}
    for g in ("kept", "drawn", "frame_ms"):
        out[g] = {name: col[f"{g}_{name}"] for name in _GROUPS[g]}
    window = col.get("window_s")
    out["window_s"] = float(window[0]) if window is not None and len(window) else float("nan")
    return out
