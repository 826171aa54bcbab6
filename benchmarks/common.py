"""What every script in benchmarks/ shares: where results go, the JSON header, the timed loop, the A/B runner.

A script imports it as ``common`` (each script puts its own folder first on ``sys.path``, so a child process
started in another source tree still uses this checkout's copy). Nothing here imports ``grasswidget`` at import
time: an A/B child imports the tree's package under test, and ``startup.py`` times the first import.

Results: ``benchmarks/results/<claim>-<machine>-<date>.json`` (:func:`result_path`), e.g.
``presets_ab-lavapipe-2026-11-27.json``; ``claim`` names what was measured (lower case, digits and ``_``),
``machine`` the adapter (:func:`machine_tag`: ``lavapipe``, ``swiftshader``, ``h100``, ...), ``date`` the UTC day
of the run. Every file starts with the header of :func:`header`: ``machine``, ``adapter``, ``date``, ``commit``,
``command``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import re
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterable, Optional, Sequence

#: The checkout this file belongs to.
ROOT = Path(__file__).resolve().parents[1]
#: Where results are written: one JSON file per measured claim.
RESULTS = ROOT / "benchmarks" / "results"
#: The keys of the header every result starts with.
HEADER_KEYS = ("machine", "adapter", "date", "commit", "command")
#: ``--out -``: print the result, write no file.
NO_FILE = "-"

_CLAIM = re.compile(r"^[a-z0-9][a-z0-9_]*$")


def use_this_checkout() -> None:
    """Put this checkout first on ``sys.path``, so that ``import grasswidget`` (and ``benchmarks.*``) is this
    checkout's even where another copy is installed. Only for scripts that measure one tree: an A/B child must
    import the tree it was started in (PYTHONPATH), so the A/B scripts do not call it."""
    if str(ROOT) not in sys.path[:1]:
        sys.path.insert(0, str(ROOT))


# ------------------------------------------------------------------ naming and the header


def machine_tag(adapter) -> str:
    """A short name of the adapter for file names: ``lavapipe`` (Mesa's llvmpipe), ``swiftshader``, ``h100``,
    ``h200``, else the device's name in lower case with ``-`` between words (at most 32 characters).
    ``adapter``: a wgpu adapter-info dict (``device``, ``description``, ``summary``), or a string."""
    if isinstance(adapter, dict):
        text = " ".join(str(adapter.get(k) or "") for k in ("device", "description", "summary", "architecture"))
    else:
        text = str(adapter or "")
    low = text.lower()
    if "llvmpipe" in low or "lavapipe" in low:
        return "lavapipe"
    if "swiftshader" in low:
        return "swiftshader"
    for gpu in ("h100", "h200", "a100", "l40s"):
        if gpu in low:
            return gpu
    name = str((adapter.get("device") or adapter.get("summary") or "") if isinstance(adapter, dict) else text)
    slug = re.sub(r"[^a-z0-9]+", "-", name.lower().split("(")[0]).strip("-")[:32].strip("-")
    return slug or "unknown"


def result_path(claim: str, machine: str, date: Optional[_dt.date] = None) -> Path:
    """``RESULTS/<claim>-<machine>-<YYYY-MM-DD>.json``. ``claim``: lower-case letters, digits and ``_``
    (the ``-`` separates the three parts); ``machine``: see :func:`machine_tag`; ``date``: default today (UTC)."""
    if not _CLAIM.match(claim):
        raise ValueError(f"claim must be lower-case letters, digits and '_' (it names the file); got {claim!r}")
    if not machine or "/" in machine or machine.startswith("."):
        raise ValueError(f"machine must be a plain name such as 'lavapipe'; got {machine!r}")
    day = (date or _dt.datetime.now(_dt.timezone.utc).date()).isoformat()
    return RESULTS / f"{claim}-{machine}-{day}.json"


def git_commit(root: Path = ROOT) -> dict:
    """``{"sha": ..., "dirty": bool}`` of the checkout at ``root`` (``sha`` None outside a git checkout);
    changes under benchmarks/results/ do not count as dirty."""
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                             timeout=10).stdout.strip() or None
        status = subprocess.run(["git", "status", "--porcelain", "--", ".", ":!benchmarks/results"], cwd=root,
                                capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.SubprocessError):
        return {"sha": None, "dirty": None}
    return {"sha": sha, "dirty": bool(status.strip()) if sha else None}


def machine_info() -> dict:
    """Host, platform, Python, CPU count and the 1/5/15-minute load averages now."""
    info = {"host": platform.node(), "platform": platform.platform(), "python": platform.python_version(),
            "cpus": os.cpu_count()}
    if hasattr(os, "getloadavg"):
        info["load_average"] = [round(v, 2) for v in os.getloadavg()]
    return info


def kernel_adapter() -> dict:
    """The adapter grasswidget renders with in this process (wgpu's adapter info plus ``summary``)."""
    from grasswidget.gpu.adapter import adapter_info

    return adapter_info()


def header(adapter, argv: Optional[Sequence[str]] = None) -> dict:
    """The header every result starts with: ``machine`` (:func:`machine_info`), ``adapter`` (as given: a dict
    or a string such as ``"google swiftshader"``), ``date`` (UTC, ISO 8601 to the second), ``commit``
    (:func:`git_commit`), ``command`` (the command line, default this process's)."""
    args = list(sys.argv if argv is None else argv)
    if args and args[0].endswith(".py"):
        script = Path(args[0]).resolve()
        args[0] = str(script.relative_to(ROOT)) if script.is_relative_to(ROOT) else str(script)
        args.insert(0, "python")
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0)
    return {"machine": machine_info(), "adapter": adapter, "date": now.isoformat(), "commit": git_commit(),
            "command": shlex.join(args)}


def add_out_argument(parser: argparse.ArgumentParser, claim: str) -> None:
    """``--out PATH`` (also spelled ``--json``): where the result goes; default
    ``benchmarks/results/<claim>-<machine>-<date>.json``; ``-`` prints it and writes no file."""
    parser.add_argument("--out", "--json", dest="out", default=None, metavar="PATH",
                        help=f"JSON file to write (default benchmarks/results/{claim}-<machine>-<date>.json; "
                             f"'{NO_FILE}': print only)")


def save(claim: str, data: dict, adapter, out=None, argv: Optional[Sequence[str]] = None,
         machine: Optional[str] = None) -> Optional[Path]:
    """Write ``header(adapter) + data`` as JSON and return the path (None with ``out == "-"``).

    ``out``: a path, ``"-"`` (no file) or None (:func:`result_path` of ``claim`` and ``machine``, which defaults
    to :func:`machine_tag` of ``adapter``). ``data`` must not use a header key (ValueError)."""
    clash = sorted(set(data) & set(HEADER_KEYS))
    if clash:
        raise ValueError(f"result keys {clash} are the header's; rename them")
    result = {**header(adapter, argv), **data}
    if out == NO_FILE:
        print(json.dumps(result, indent=1, default=str))
        return None
    path = Path(out) if out else result_path(claim, machine or machine_tag(adapter))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=1, default=str) + "\n")
    print(f"wrote {path}", flush=True)
    return path


# ------------------------------------------------------------------ the settings a row runs with

#: The culling settings of :func:`set_culling`: everything culled, nothing, or one test alone.
CULLING = ("on", "off", "orientation", "frustum", "distance")


def set_culling(params, culling: str, occlusion: bool = False, compute_raster: Optional[bool] = None,
                raster_max_px: Optional[float] = None) -> None:
    """Set a GrassParams as ``grasswidget bench`` runs a row, through its public traits only (so a child in an
    older source tree takes it too): ``culling`` "on" (the three culling tests and LOD), "off" (nothing culled,
    no LOD) or one test alone with LOD ("orientation", "frustum", "distance"); occlusion culling with
    ``occlusion`` unless ``culling`` is "off"; ``compute_raster`` True/False (None leaves it); ``raster_max_px``
    the compute rasterizer's largest projected blade width in pixels (None leaves it)."""
    if culling not in CULLING:
        raise ValueError(f"culling must be one of {', '.join(CULLING)}; got {culling!r}")
    params.cull_orientation = culling in ("on", "orientation")
    params.cull_frustum = culling in ("on", "frustum")
    params.cull_distance = culling in ("on", "distance")
    params.lod = culling != "off"
    params.cull_occlusion = bool(occlusion) and culling != "off"
    if compute_raster is not None:
        params.compute_raster = bool(compute_raster)
    if raster_max_px is not None:
        params.compute_raster_max_px = raster_max_px


#: The views :func:`preset_scene` makes: the widget's start, and GrassScene's presets.
PRESET_VIEWS = ("default", "cis565", "meadow")


def preset_scene(preset: str, blades: int, size=None):
    """The scene a benchmark times: ``preset`` "default" (``Blades.on_plane(blades, seed=0)`` at ``size`` or
    640x480, the widget's start) or a ``GrassScene.preset`` name (seed 0, its own size unless ``size``)."""
    import grasswidget as gw
    from grasswidget.gpu.scene import GrassScene

    if preset not in PRESET_VIEWS:
        raise ValueError(f"preset must be one of {', '.join(PRESET_VIEWS)}; got {preset!r}")
    if preset == "default":
        return GrassScene(gw.Blades.on_plane(int(blades), seed=0), size=size or (640, 480))
    return GrassScene.preset(preset, blades=int(blades), seed=0, size=size)


# ------------------------------------------------------------------ the timed loop


def median(values: Iterable[float]) -> float:
    """The median, NaN for no values."""
    values = list(values)
    return float(statistics.median(values)) if values else float("nan")


def percentile(values: Iterable[float], q: float) -> float:
    """The ``q``-th percentile (0-100, linear interpolation), NaN for no values."""
    values = sorted(values)
    if not values:
        return float("nan")
    pos = (len(values) - 1) * q / 100.0
    lo = int(pos)
    hi = min(lo + 1, len(values) - 1)
    return float(values[lo] + (values[hi] - values[lo]) * (pos - lo))


def time_frames(frame: Callable[[], object], frames: int, warmup: int = 3, repeats: int = 1) -> dict:
    """Call ``frame()`` ``warmup`` times untimed, then ``frames`` samples of ``repeats`` calls each.

    Returns ``{"wall_ms": [...], "cpu_ms": [...]}``: per sample the wall time and this process's CPU time (all
    threads: on a CPU adapter the rendering work itself, much steadier than wall time on a loaded machine), in
    ms per call. ``frame`` must wait for the GPU itself (e.g. a small readback) if the GPU's time is to count."""
    if frames < 1 or warmup < 0 or repeats < 1:
        raise ValueError(f"frames >= 1, warmup >= 0 and repeats >= 1; got {frames}, {warmup}, {repeats}")
    for _ in range(warmup):
        frame()
    wall, cpu = [], []
    for _ in range(frames):
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(repeats):
            frame()
        cpu.append(1e3 * (time.process_time() - c0) / repeats)
        wall.append(1e3 * (time.perf_counter() - t0) / repeats)
    return {"wall_ms": wall, "cpu_ms": cpu}


def interleave(measures: dict, rounds: int, warmup: int = 1) -> dict:
    """In one process: call every ``measures[name]()`` (each returns one sample, e.g. ms) ``warmup`` times
    untimed, then once per round each, in turn (reversed every other round), so that a noisy machine loads them
    alike. Returns ``{name: [one sample per round]}``."""
    if rounds < 1:
        raise ValueError(f"rounds must be at least 1; got {rounds}")
    names = list(measures)
    for _ in range(warmup):
        for name in names:
            measures[name]()
    samples = {name: [] for name in names}
    for r in range(rounds):
        for name in names if r % 2 == 0 else names[::-1]:
            samples[name].append(measures[name]())
    return samples


def time_pipelined(frame: Callable[[], object], frames: int, sync: Callable[[], object]) -> dict:
    """``frames`` calls of ``frame()`` back to back (the GPU may run behind, as in a live view), with one
    ``sync()`` (wait for the GPU) before and one after. Returns ms per frame: ``wall_ms`` (to the final sync),
    ``cpu_ms`` (this process, all threads), ``main_thread_cpu_ms`` (this thread, the submitting loop alone,
    before the final sync) and ``fps`` (1000 / ``wall_ms``)."""
    if frames < 1:
        raise ValueError(f"frames must be at least 1; got {frames}")
    sync()
    t0, c0, m0 = time.perf_counter(), time.process_time(), time.thread_time()
    for _ in range(frames):
        frame()
    main_ms = 1e3 * (time.thread_time() - m0) / frames
    sync()
    wall_ms = 1e3 * (time.perf_counter() - t0) / frames
    return {"wall_ms": wall_ms, "cpu_ms": 1e3 * (time.process_time() - c0) / frames, "main_thread_cpu_ms": main_ms,
            "fps": 1e3 / wall_ms}


def summary_ms(samples: dict) -> dict:
    """Median, p10 and p90 of each list of :func:`time_frames`' result."""
    return {k: {"median": median(v), "p10": percentile(v, 10), "p90": percentile(v, 90)} for k, v in samples.items()}


# ------------------------------------------------------------------ the A/B runner


def parse_trees(specs: Sequence[str], minimum: int = 2, suffixes: Sequence[str] = ()) -> list:
    """``["base=/tmp/old", "new=."]`` -> ``[("base", "/tmp/old"), ("new", ".")]`` (the first is the baseline);
    each folder must hold a ``grasswidget`` package. A folder may end in one of ``suffixes`` (e.g. ``":two"``,
    a variant of the tree the script defines): it is checked without it and kept in the returned folder."""
    trees = []
    for spec in specs:
        name, sep, folder = spec.partition("=")
        bare = next((folder[: -len(s)] for s in suffixes if folder.endswith(s)), folder)
        if not sep or not name or not folder:
            raise SystemExit(f"--tree takes NAME=DIR; got {spec!r}")
        if not (Path(bare) / "grasswidget" / "__init__.py").is_file():
            raise SystemExit(f"--tree {spec}: {bare} holds no grasswidget package")
        trees.append((name, folder))
    if len({n for n, _ in trees}) != len(trees):
        raise SystemExit(f"--tree names must differ; got {[n for n, _ in trees]}")
    if len(trees) < minimum:
        raise SystemExit(f"give at least {minimum} --tree NAME=DIR")
    return trees


#: A child's result line starts with this.
RESULT_MARK = "RESULT "


def emit(result) -> None:
    """In a child process: print ``result`` as the line :func:`run_in_tree` reads."""
    print(RESULT_MARK + json.dumps(result), flush=True)


def run_in_tree(folder: str, argv: Sequence[str], timeout: float = 3600) -> dict:
    """Run ``python <argv>`` in a fresh process whose ``grasswidget`` is ``folder``'s (first on PYTHONPATH, and the
    working directory) and return what it passed to :func:`emit`. A failure raises RuntimeError with its stderr."""
    rest = os.environ.get("PYTHONPATH", "")
    env = dict(os.environ, PYTHONPATH=os.path.abspath(folder) + (os.pathsep + rest if rest else ""))
    proc = subprocess.run([sys.executable, *argv], cwd=os.path.abspath(folder), env=env, capture_output=True,
                          text=True, timeout=timeout)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith(RESULT_MARK)]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"{' '.join(argv)} in {folder} failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
    return json.loads(lines[-1][len(RESULT_MARK):])


def run_ab(trees: Sequence[tuple], cases: Sequence, rounds: int, measure: Callable[[str, str, object], dict],
           progress: bool = True) -> list:
    """Interleave the trees: each round runs, for every case, ``measure(name, folder, case)`` once per tree in turn,
    in reverse order every other round (a machine whose speed drifts loads the trees alike).
    Returns one row per (round, case): ``{"round", "case", <tree name>: measure's dict, ...}``."""
    rows = []
    for r in range(rounds):
        order = list(trees) if r % 2 == 0 else list(trees)[::-1]
        for case in cases:
            row = {"round": r, "case": case}
            for name, folder in order:
                t = time.perf_counter()
                row[name] = measure(name, folder, case)
                if progress:
                    print(f"round {r} {case} {name}: {time.perf_counter() - t:.1f} s", file=sys.stderr, flush=True)
            rows.append(row)
    return rows


def ab_summary(rows: Sequence[dict], trees: Sequence[tuple], keys: Sequence[str]) -> dict:
    """Per case and tree: the median over rounds of each of ``keys``, and for every tree after the first the
    median of the per-round ratios tree / first tree (``<key>_ratio``): the figure to quote on a loaded machine."""
    base = trees[0][0]
    out = {}
    for case in dict.fromkeys(row["case"] for row in rows):
        mine = [row for row in rows if row["case"] == case]
        out[str(case)] = {}
        for name, _ in trees:
            entry = {k: median(row[name][k] for row in mine) for k in keys}
            if name != base:
                for k in keys:
                    entry[f"{k}_ratio"] = median(row[name][k] / row[base][k] for row in mine if row[base][k])
            out[str(case)][name] = entry
    return out
