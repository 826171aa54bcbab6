"""The browser engine on Dawn (Chrome's WebGPU) without a browser: frames/s, GPU ms per pass,
and its picture against the kernel engine's.

Python builds what the page of ``GrassWidget(n, preset="meadow", size=..., backend="browser")``
gets, the meadow preset exactly as a user gets it (the field to the horizon, the preset's camera and
parameters, the sunlight's default for the page's adapter, ``--adapter``; the engine's ES module,
``BrowserEngineWidget._esm``; every synced trait of the widget's BrowserEngineWidget: blades, packed uniforms,
the rendered WGSL, frame rules, camera) at each blade count, and the kernel engine's picture of the
same state (the same blades and params, ``STEPS`` fixed steps from rest, the preset's camera;
``GrassScene.render_at(antialias=False)``, like a live frame) with its count of blades drawn. It writes
them to a folder; ``benchmarks/dawn/run_engine.mjs`` (node + the npm package ``webgpu`` 0.6.2,
dawn.node) loads the module with a small shim (an ``el``, a canvas whose WebGPU context draws
into a device texture, ``requestAnimationFrame`` driven by a loop, the model with the traits),
plays the meadow and measures:

* frames/s: frames the GPU completed per second of wall time while playing, over ``--seconds``
  (after a warm-up second), as the engine's own loop submits them;
* GPU ms per pass, per frame: timestamp queries around every pass the engine encodes (where the
  adapter has ``timestamp-query``; Dawn's timestamp quantization off), over 30 frames;
* the picture: reset, ``STEPS`` steps while paused, one frame read back, against the kernel's
  picture: mean absolute difference (0..255 over RGB) and the share of pixels that differ by
  more than 40 in some channel, passing when the mean is at most ``TOLERANCE_MEAN`` and the
  share at most ``TOLERANCE_SHARE``.

Usage (from the repository root)::

    # here (SwiftShader through Debian's Chromium's Vulkan driver), a small case:
    .venv/bin/python benchmarks/browser_engine_dawn.py --blades 4096 --size 320x240
    # the states alone (for another machine): --prepare-only --states DIR
    # the GPU machine: benchmarks/dawn/prepare_device.sh here, then the command it prints there.
    # issue 28's matrix (the "auto" defaults against every fixed combination), Python answering the engine:
    .venv/bin/python benchmarks/browser_engine_dawn.py --matrix --rows meadow:16384:320x240

Results: benchmarks/results/browser_engine_dawn-<machine>-<date>.json (``--matrix``: browser_matrix_dawn-...;
``--out`` names another file), the machine named after Dawn's adapter (``swiftshader`` here).

``--matrix`` runs no written state: the Python widget itself (``GrassWidget(backend="browser")``) is
the kernel of a page in node (:class:`benchmarks.dawn_page.DawnPage`, ``benchmarks/dawn/serve_engine.mjs``),
and :func:`benchmarks.browser_matrix.run_matrix` (the same as ``browser_engine.py --matrix``) runs the
rows: every fixed setting compiled, "auto" decided by the widget's own code from the engine's frame
times, then the five settings interleaved in rounds (frames/s of the GPU's completed frames: node's
loop is not held to a display's refresh).

The npm package is fetched once (``npm pack webgpu@0.6.2``) and unpacked into
``benchmarks/.dawn/`` (ignored by git); ``--dawn DIR`` names an unpacked package instead.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tarfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

common.use_this_checkout()
ROOT = common.ROOT

#: The npm package (Dawn as a node addon) and where it is unpacked.
DAWN_PACKAGE = "webgpu@0.6.2"
DAWN_DIR = ROOT / "benchmarks" / ".dawn"
RUNNER = ROOT / "benchmarks" / "dawn" / "run_engine.mjs"
#: SwiftShader's Vulkan driver, shipped by Debian's chromium package (Dawn refuses Mesa 22's lavapipe).
SWIFTSHADER_ICD = "/usr/lib/chromium/vk_swiftshader_icd.json"
#: Fixed steps from the rest pose before the compared frame (1 s of simulated time at dt = 1/120).
STEPS = 120
#: The picture passes when mean |Dawn - kernel| <= this (0..255, over RGB) ...
TOLERANCE_MEAN = 3.0
#: ... and at most this share of the pixels differ by more than 40 in some channel (thin blades
#: land on slightly different pixels in two rasterizers).
TOLERANCE_SHARE = 0.03
DEFAULT_BLADES = (1 << 16, 1 << 18, 1 << 20)
#: --matrix's rows on the GPU machine (preset:blades:WxH): issue 28's scenes.
MATRIX_ROWS = ("meadow:65536:1920x1080", "meadow:262144:1920x1080", "meadow:1048576:1920x1080",
               "cis565:65536:640x480", "cis565:1048576:640x480")


def parse_row(text: str):
    """"preset:blades:WxH" as (preset, blades, (w, h)); a clear error naming --rows otherwise."""
    from grasswidget.core.presets import parse_size

    parts = text.split(":")
    if len(parts) != 3 or not parts[1].isdigit() or int(parts[1]) < 1:
        raise SystemExit(f"--rows: each row is preset:blades:WxH (e.g. meadow:65536:1920x1080); got {text!r}")
    return parts[0], int(parts[1]), tuple(parse_size(parts[2]))


def run_matrix(rows, dawn: Path, out, rounds: int, window_s: float, env=None, node=None) -> dict:
    """Issue 28's matrix through Dawn (see the module docstring): the JSON (also written to ``out``; None:
    benchmarks/results/browser_matrix_dawn-<machine>-<date>.json), shaped as ``browser_engine.py --matrix``'s."""
    import browser_matrix
    from dawn_page import DawnPage

    result = {"load_average_before": list(os.getloadavg())}
    written = {"path": out}

    def save(matrix):  # after each row, to the same file: what was measured survives a later row's failure
        result["matrix"] = matrix
        result["load_average_after"] = list(os.getloadavg())
        written["path"] = common.save("browser_matrix_dawn", result, result["dawn"]["adapter"], written["path"])

    with DawnPage(dawn, env=env, node=node) as page:
        result["dawn"] = {"package": DAWN_PACKAGE, "node": page.ready.get("node"), "adapter": page.ready["adapter"]}
        print(f"Dawn adapter: {page.ready['adapter']}", flush=True)
        save(browser_matrix.run_matrix(page, rows, rounds=rounds, window_s=window_s, on_row=save))
    print(browser_matrix.markdown_table(result["matrix"]))
    return result


def engine_module() -> str:
    """The browser engine's ES module, as the anywidget and the live page get it."""
    from grasswidget.browser.engine_widget import BrowserEngineWidget

    return BrowserEngineWidget._esm


def _json_or_none(value):
    try:
        json.dumps(value)
        return value
    except TypeError:
        return None


#: How the page's adapter is reported to the widget (its ``gpu_status`` detail, as engine.js words it), for
#: the sunlight's default (``core.params.sunlight_defaults``: shadows on a GPU, off on a CPU adapter).
ADAPTER_WORDS = {"swiftshader": "google swiftshader SwiftShader Device (Subzero)", "gpu": "nvidia hopper NVIDIA H200"}


def user_state(n_blades: int, size, adapter: str = "swiftshader"):
    """The meadow preset exactly as a user gets it in the browser engine:
    ``GrassWidget(n_blades, preset="meadow", size=size, backend="browser")`` (the field to the horizon,
    the preset's camera and parameters), its page reporting ``adapter`` (a key of :data:`ADAPTER_WORDS`)
    so that the sunlight takes that adapter's default. Returns the open widget (close it)."""
    import grasswidget as gw

    if adapter not in ADAPTER_WORDS:
        raise SystemExit(f"--adapter must be one of {', '.join(ADAPTER_WORDS)}; got {adapter!r}")
    w = gw.GrassWidget(n_blades, preset="meadow", size=tuple(size), backend="browser")
    w.view.engine_widget.gpu_status = {"state": "ok", "detail": ADAPTER_WORDS[adapter]}
    return w


def write_case(states: Path, n_blades: int, size, steps: int = STEPS, kernel_picture: bool = True,
               adapter: str = "swiftshader") -> dict:
    """One case's files under ``states``: traits JSON, the byte traits, the kernel's picture.
    Returns its manifest entry.

    The state is the browser-engine widget's own (:func:`user_state`): every synced trait of its
    BrowserEngineWidget, set playing. The kernel's picture is ``GrassScene.preset("meadow")`` of the
    same blades, parameters (a copy of the widget's) and camera, ``steps`` steps from rest."""
    name = f"meadow_{n_blades}_{size[0]}x{size[1]}"
    folder = states / name
    folder.mkdir(parents=True, exist_ok=True)
    w = user_state(n_blades, size, adapter)
    try:
        bv = w.view.engine_widget
        blades, params = bv.blades, w.params.copy()
        bv.playing = True
        traits, byte_traits = {}, {}
        for trait in sorted(bv.trait_names(sync=True)):
            if trait.startswith("_") or trait in ("layout", "tabbable", "tooltip", "comm", "keys", "log"):
                continue
            value = getattr(bv, trait)
            if isinstance(value, (bytes, bytearray, memoryview)):
                (folder / f"{trait}.bin").write_bytes(bytes(value))
                byte_traits[trait] = f"{name}/{trait}.bin"
            elif _json_or_none(value) is not None or value is None:
                traits[trait] = value
        (folder / "traits.json").write_text(json.dumps(traits))
        scene_of_the_user = {"horizon": blades.horizon is not None, "shadows": bool(params.shadows),
                             "camera": _json_or_none(traits.get("camera")), "adapter": adapter}
    finally:
        w.close()
    entry = {"name": name, "blades": n_blades, "width": size[0], "height": size[1], "steps": steps,
             "traits": f"{name}/traits.json", "byte_traits": byte_traits, "kernel_picture": None,
             "scene": scene_of_the_user}
    if kernel_picture:
        from grasswidget.gpu.adapter import adapter_info
        from grasswidget.gpu.scene import GrassScene

        t0 = time.perf_counter()
        scene = GrassScene.preset("meadow", blades=blades, size=size, params=params)
        try:
            scene.step(steps)
            img = np.ascontiguousarray(scene.render_at(size, antialias=False)[..., :4], np.uint8)
            entry["kernel_visible"] = int(scene.visible_count())  # the kernel's count of blades drawn in it
        finally:
            scene.release()
        (folder / "kernel.rgba").write_bytes(img.tobytes())
        entry["kernel_picture"] = f"{name}/kernel.rgba"
        entry["kernel_adapter"] = str(adapter_info().get("summary", ""))
        entry["kernel_picture_s"] = round(time.perf_counter() - t0, 2)
    return entry


def prepare(states: Path, counts, size, steps: int = STEPS, kernel_picture: bool = True,
            adapter: str = "swiftshader") -> Path:
    """The engine module and every case's state under ``states`` (the page's adapter ``adapter``, see
    :func:`user_state`); returns the manifest's path."""
    states.mkdir(parents=True, exist_ok=True)
    (states / "engine.mjs").write_text(engine_module(), encoding="utf-8")
    cases = [write_case(states, n, size, steps, kernel_picture, adapter) for n in counts]
    manifest = {"engine": "engine.mjs", "cases": cases, "tolerance": {"mean": TOLERANCE_MEAN,
                                                                       "share_over_40": TOLERANCE_SHARE}}
    path = states / "manifest.json"
    path.write_text(json.dumps(manifest, indent=1))
    return path


def fetch_dawn(dest: Path = DAWN_DIR) -> Path:
    """The unpacked npm package ``webgpu`` (dawn.node inside): ``npm pack`` it once into ``dest``."""
    package = dest / "package"
    if (package / "dist" / "linux-x64" / "dawn.node").exists():
        return package
    dest.mkdir(parents=True, exist_ok=True)
    npm = shutil.which("npm")
    if npm is None:
        raise SystemExit("npm is needed once to fetch the webgpu package (or pass --dawn DIR)")
    out = subprocess.run([npm, "pack", DAWN_PACKAGE, "--pack-destination", str(dest)], capture_output=True,
                         text=True, timeout=600)
    if out.returncode != 0:
        raise SystemExit(f"npm pack {DAWN_PACKAGE} failed: {out.stderr.strip()}")
    tgz = dest / out.stdout.strip().splitlines()[-1]
    with tarfile.open(tgz) as tar:
        tar.extractall(dest, filter="data")
    tgz.unlink()
    return package


def run_node(manifest: Path, out_json: Path, dawn: Path, seconds: float, env=None, timeout: float = 1800,
             warmup: float = 1.0, profile_frames: int = 30) -> dict:
    """Run the node benchmark on ``manifest`` (``seconds`` of playing measured after ``warmup``
    seconds, then ``profile_frames`` frames timed pass by pass); returns its JSON (also written
    to ``out_json``)."""
    node = shutil.which("node") or shutil.which("nodejs")
    if node is None:
        raise SystemExit("node is needed (Debian's nodejs)")
    env = dict(os.environ if env is None else env)
    cmd = [node, str(RUNNER), "--manifest", str(manifest), "--out", str(out_json), "--dawn", str(dawn),
           "--seconds", str(seconds), "--warmup", str(warmup), "--profile-frames", str(int(profile_frames))]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    sys.stdout.write(run.stdout)
    if run.returncode != 0:
        raise RuntimeError(f"node benchmark failed ({run.returncode}):\n{run.stderr[-4000:]}")
    return json.loads(out_json.read_text())


#: What a carried bundle may weigh (the device machine takes 64 MiB of ignored paths a call).
BUNDLE_LIMIT = 60 * 2 ** 20


def _xz(folder: Path, name: str, members, preset: int = 3) -> Path:
    """``members`` ((path, arcname) pairs) into ``folder/name.tar.xz`` (Python's lzma unpacks it there)."""
    path = folder / f"{name}.tar.xz"
    with tarfile.open(path, "w:xz", preset=preset) as tar:
        for src, arc in members:
            tar.add(src, arcname=arc)
    return path


def bundle(dest: Path, counts, size, node: Path, vulkan_root: Path, steps: int = STEPS, adapter: str = "gpu") -> list:
    """What the GPU machine needs, compressed under ``dest``: ``common.tar.xz`` (node, dawn.node and the
    package's index.js, the Vulkan loader, the engine module) and one ``case_<n>.tar.xz`` per blade
    count (the traits, the blades, the kernel engine's picture, rendered here). Returns the groups of
    paths to carry, each under :data:`BUNDLE_LIMIT` (one run call each, on the same warm machine)."""
    import tempfile

    dest.mkdir(parents=True, exist_ok=True)
    dawn = fetch_dawn()
    with tempfile.TemporaryDirectory(prefix="gw-dawn-bundle-") as tmp:
        states = Path(tmp) / "states"
        states.mkdir()
        (states / "engine.mjs").write_text(engine_module(), encoding="utf-8")
        common = _xz(dest, "common", [(node, "node/node"), (dawn / "index.js", "webgpu/index.js"),
                                      (dawn / "package.json", "webgpu/package.json"),
                                      (dawn / "dist" / "linux-x64" / "dawn.node", "webgpu/dist/linux-x64/dawn.node"),
                                      (vulkan_root, "vulkan"), (states / "engine.mjs", "states/engine.mjs")],
                     preset=6)
        files = [common]
        for n in counts:
            entry = write_case(states, n, size, steps, adapter=adapter)
            manifest = {"engine": "engine.mjs", "cases": [entry],
                        "tolerance": {"mean": TOLERANCE_MEAN, "share_over_40": TOLERANCE_SHARE}}
            (states / f"manifest_{n}.json").write_text(json.dumps(manifest, indent=1))
            files.append(_xz(dest, f"case_{n}", [(states / entry["name"], f"states/{entry['name']}"),
                                                  (states / f"manifest_{n}.json", f"states/manifest_{n}.json")]))
            shutil.rmtree(states / entry["name"])
    groups, current, weight = [], [], 0
    for f in files:
        size_f = f.stat().st_size
        if current and weight + size_f > BUNDLE_LIMIT:
            groups.append(current)
            current, weight = [], 0
        current.append(f)
        weight += size_f
    groups.append(current)
    return groups


def frame_difference(frame: np.ndarray, kernel: np.ndarray) -> dict:
    """The metric of the picture check, in NumPy (run_engine.mjs computes the same in JS):
    mean |a - b| over RGB (0..255) and the share of pixels differing by > 40 in some channel."""
    diff = np.abs(frame[..., :3].astype(np.int32) - kernel[..., :3].astype(np.int32))
    return {"mean_abs": float(diff.mean()), "share_over_40": float((diff.max(axis=2) > 40).mean())}


def swiftshader_env() -> dict:
    env = dict(os.environ)
    env.setdefault("VK_ICD_FILENAMES", SWIFTSHADER_ICD)
    env.setdefault("XDG_RUNTIME_DIR", "/tmp")
    return env


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blades", type=int, nargs="+", default=list(DEFAULT_BLADES))
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--seconds", type=float, default=5.0, help="seconds of playing measured per case")
    ap.add_argument("--steps", type=int, default=STEPS)
    ap.add_argument("--states", default=None, help="folder for the states (default: a temporary one)")
    ap.add_argument("--dawn", default=None, help="an unpacked webgpu npm package (default: fetched into "
                                                 "benchmarks/.dawn)")
    ap.add_argument("--prepare-only", action="store_true", help="write the states and kernel pictures, run nothing")
    ap.add_argument("--no-kernel-picture", action="store_true")
    ap.add_argument("--adapter", choices=sorted(ADAPTER_WORDS), default=None,
                    help="the adapter the page reports to the widget, for the sunlight's default (default: "
                         "swiftshader here, gpu for --bundle)")
    common.add_out_argument(ap, "browser_engine_dawn")
    ap.add_argument("--bundle", default=None, help="write the GPU machine's bundles into this folder "
                                                   "(benchmarks/dawn/prepare_device.sh uses it)")
    ap.add_argument("--node", default=shutil.which("node") or "", help="the node binary to carry (--bundle)")
    ap.add_argument("--vulkan", default=None, help="the unpacked libvulkan1 root to carry (--bundle)")
    ap.add_argument("--matrix", action="store_true",
                    help="issue 28's matrix: the 'auto' defaults against every fixed combination of occlusion "
                         "culling and the compute rasterizer, Python's widget answering the engine")
    ap.add_argument("--rows", nargs="+", default=list(MATRIX_ROWS), help="--matrix's rows, preset:blades:WxH")
    ap.add_argument("--rounds", type=int, default=None, help="--matrix's rounds (default browser_matrix's)")
    ap.add_argument("--window", type=float, default=None, help="--matrix's seconds a window lasts at least")
    args = ap.parse_args(argv)
    from grasswidget.core.presets import parse_size

    if args.matrix:
        import browser_matrix

        if args.rounds is not None and args.rounds < 1:
            ap.error(f"--rounds must be an integer >= 1; got {args.rounds}")
        if args.window is not None and not args.window > 0:
            ap.error(f"--window must be seconds > 0; got {args.window}")

        dawn = Path(args.dawn) if args.dawn else fetch_dawn()
        run_matrix([parse_row(r) for r in args.rows], dawn, args.out,
                   args.rounds if args.rounds is not None else browser_matrix.MATRIX_ROUNDS,
                   args.window if args.window is not None else browser_matrix.MATRIX_WINDOW_S,
                   env=swiftshader_env(), node=args.node or None)
        return 0

    size = parse_size(args.size)
    import tempfile

    if args.bundle:
        groups = bundle(Path(args.bundle), args.blades, size, Path(args.node), Path(args.vulkan), args.steps,
                        adapter=args.adapter or "gpu")
        for k, group in enumerate(groups, 1):
            weight = sum(f.stat().st_size for f in group) / 2 ** 20
            carry = json.dumps([str(f.relative_to(ROOT)) if f.is_relative_to(ROOT) else str(f) for f in group])
            cases = " ".join(f.name[len("case_"):-len(".tar.xz")] for f in group if f.name.startswith("case_"))
            print(f"call {k} of {len(groups)} ({weight:.1f} MiB; one warm machine, in this order): carry={carry} "
                  f"command: CASES='{cases}' bash benchmarks/dawn/run_on_device.sh")
        return 0
    states = Path(args.states) if args.states else Path(tempfile.mkdtemp(prefix="gw-dawn-states-"))
    manifest = prepare(states, args.blades, size, args.steps, kernel_picture=not args.no_kernel_picture,
                       adapter=args.adapter or "swiftshader")
    print(f"states: {states}")
    if args.prepare_only:
        return 0
    dawn = Path(args.dawn) if args.dawn else fetch_dawn()
    result = run_node(manifest, states / "dawn_result.json", dawn, args.seconds, env=swiftshader_env())
    import imageio.v3 as iio

    counts_agree = True
    for case, entry in zip(result["cases"], json.loads(manifest.read_text())["cases"]):
        w, h = case["width"], case["height"]
        if entry.get("kernel_visible") is not None and case.get("visible_stepped"):
            drawn = sum(case["visible_stepped"])
            # the engine's count of the compared state (stepped, paused) against the kernel's of the same
            # state: the same rules, a few blades apart where the two engines round differently
            case["blades_drawn"] = {"engine": drawn, "kernel": entry["kernel_visible"],
                                    "pass": abs(drawn - entry["kernel_visible"]) <= 0.05 * max(entry["kernel_visible"], 1)}
            counts_agree &= case["blades_drawn"]["pass"]
            print(f"{case['name']}: blades drawn: engine {drawn}, kernel {entry['kernel_visible']}")
        frame = np.frombuffer(Path(case["frame_file"]).read_bytes(), np.uint8).reshape(h, w, 4)
        if entry.get("kernel_picture"):
            kernel = np.frombuffer((states / entry["kernel_picture"]).read_bytes(), np.uint8).reshape(h, w, 4)
            frame = np.concatenate([kernel, frame], axis=1)
        picture = states / f"{case['name']}_kernel_dawn.png"
        iio.imwrite(picture, frame)
        print(f"{case['name']}: kernel | Dawn side by side: {picture}")
    adapter = result.pop("adapter")
    common.save("browser_engine_dawn", result, adapter, args.out)
    return 0 if counts_agree and all((c.get("picture") or {}).get("pass", True) for c in result["cases"]) else 1


if __name__ == "__main__":
    sys.exit(main())
