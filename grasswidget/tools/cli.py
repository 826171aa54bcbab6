"""Command line: ``grasswidget snapshot ...``, ``grasswidget html ...``, ``grasswidget sweep ...`` and
``grasswidget bench ...``.

Every bad argument is an argument error: exit status 2 and one line on stderr,
``grasswidget snapshot: error: argument --wind: ...``, never a traceback. That
covers values out of range (checked by the same traits the library uses), blade
counts that do not fit in memory (checked before anything is allocated), image
names whose extension is not .png, .jpg or .jpeg, and output folders that cannot
be created (a missing folder is created).
"""

from __future__ import annotations

import argparse
import os
import sys

from ..errors import GrassValueError

#: Image formats ``snapshot`` writes, by extension (written with imageio).
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg")
#: JPEG quality of ``snapshot out.jpg``.
JPEG_QUALITY = 95


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage block), exit 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _size(text):
    from ..gpu.scene import parse_size

    try:
        return parse_size(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _int_at_least(lo):
    """An argparse type: an integer >= lo, with a message that says so."""

    def parse(text):
        try:
            v = int(text)
        except ValueError:
            v = lo - 1
        if v < lo:
            raise argparse.ArgumentTypeError(f"must be an integer >= {lo}; got {text!r}")
        return v

    return parse


_positive = _int_at_least(1)
_non_negative = _int_at_least(0)


def _steps(text):
    """An argparse type: a step count in [0, MAX_STEPS] (grasswidget.core.limits)."""
    from ..core.limits import MAX_STEPS

    v = _non_negative(text)
    if v > MAX_STEPS:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, {MAX_STEPS}] (MAX_STEPS); got {text!r}")
    return v


def _blade_count(text):
    """A blade count >= 1 whose making fits in the host's memory (the GPU's
    buffers are checked once the device is known)."""
    from ..core.memory import BladeCountError, check_blade_count

    n = _positive(text)
    try:
        return check_blade_count(n)
    except BladeCountError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _param(name):
    """An argparse type for a GrassParams trait: the trait's own validation
    (range, finiteness) and message."""

    def parse(text):
        from traitlets import TraitError

        from ..core.params import GrassParams

        try:
            value = float(text)
        except ValueError:
            value = text
        try:
            setattr(GrassParams(), name, value)
        except TraitError as err:
            raise argparse.ArgumentTypeError(str(err)) from None
        return float(value)

    parse.__name__ = name
    return parse


def _image_path(text):
    ext = os.path.splitext(text)[1].lower()
    if ext not in IMAGE_EXTENSIONS:
        raise argparse.ArgumentTypeError(
            f"the image name must end in {', '.join(IMAGE_EXTENSIONS)} (the format follows the extension); got {text!r}"
        )
    return text


def _page_max_blades():
    from ..browser.page import PAGE_MAX_BLADES

    return PAGE_MAX_BLADES


def _page_blades(text):
    """A blade count a live page may carry (1 .. PAGE_MAX_BLADES)."""
    from ..browser.page import check_page_blades

    try:
        return check_page_blades(int(text))
    except ValueError as err:
        msg = str(err) if text.strip().lstrip("-").isdigit() else f"must be an integer; got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None


def _html_path(text):
    from ..browser.page import check_page_path

    try:
        check_page_path(text)
    except (ValueError, OSError) as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return text


def _sweep_axis(text):
    """``name=v1,v2,...``: one swept parameter and its values (numbers, or words for a choice
    trait), checked by the trait itself (:func:`grasswidget.core.variants.check_sweep_axes`)."""
    from ..core.variants import check_sweep_axes

    name, sep, rest = text.partition("=")
    if not sep or not name.strip() or not rest.strip():
        raise argparse.ArgumentTypeError(f"must be NAME=V1,V2,... (e.g. stiffness_scale=0.5,1,2); got {text!r}")
    values = []
    for item in rest.split(","):
        item = item.strip()
        try:
            values.append(float(item))
        except ValueError:
            values.append(item)
    try:
        return check_sweep_axes({name.strip(): values})
    except (ValueError, TypeError, AttributeError) as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _png_path(text):
    if not text.lower().endswith(".png"):
        raise argparse.ArgumentTypeError(f"the sheet is a PNG: the name must end in .png; got {text!r}")
    return text


def build_parser():
    p = _Parser(prog="grasswidget", description="Physically animated grass on the GPU.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("snapshot", help="simulate a field and write a PNG or JPEG")
    s.add_argument("out", type=_image_path,
                   help="output image: .png, or .jpg/.jpeg (JPEG quality 95); a missing folder is created")
    s.add_argument("--blades", type=_blade_count, default=65536, help="number of blades (default 65536)")
    s.add_argument("--size", type=_size, default=(1280, 720), help="image size WxH (default 1280x720)")
    s.add_argument("--steps", type=_steps, default=240, help="fixed simulation steps before the picture (default 240)")
    s.add_argument("--preset", choices=["default", "cis565", "meadow"], default="default", help="scene preset")
    s.add_argument("--wind", type=_param("wind_strength"), default=None,
                   help="wind strength in m/s^2, 0..200 (default: GrassParams default)")
    s.add_argument("--seed", type=_non_negative, default=0, help="random seed, an integer >= 0")
    s.add_argument("--no-horizon", action="store_true",
                   help="meadow preset: the square field on bare ground (no grass to the horizon)")

    h = sub.add_parser("html", help="write a live page: one self-contained HTML file that runs the meadow "
                                    "in any browser with WebGPU (a still picture and a line without it)")
    h.add_argument("out", type=_html_path, help="output page, ending in .html, in an existing folder")
    h.add_argument("--blades", type=_page_blades, default=16384,
                   help=f"number of blades, 1..{_page_max_blades()} (default 16384)")
    h.add_argument("--size", type=_size, default=None, help="view size WxH in CSS pixels (default: the preset's, "
                   "else 960x540)")
    h.add_argument("--preset", choices=["default", "cis565", "meadow"], default="default", help="scene preset")
    h.add_argument("--wind", type=_param("wind_strength"), default=None,
                   help="wind strength in m/s^2, 0..200 (default: GrassParams default)")
    h.add_argument("--seed", type=_non_negative, default=0, help="random seed, an integer >= 0")
    h.add_argument("--paused", action="store_true", help="start paused")
    h.add_argument("--no-still", action="store_true",
                   help="leave out the still picture shown without WebGPU (no kernel render at save time)")

    w = sub.add_parser("sweep", help="render the meadow for each setting of one or two parameters, after the "
                                     "same steps, as one labelled PNG (a row, or a grid)")
    w.add_argument("out", type=_png_path, help="output PNG; a missing folder is created")
    w.add_argument("--vary", type=_sweep_axis, action="append", required=True, metavar="NAME=V1,V2,...",
                   help="a GrassParams parameter and its values, e.g. stiffness_scale=0.25,0.5,1,2,4; once for a "
                        "row, twice for a grid (the first down, the second across)")
    w.add_argument("--steps", type=_steps, default=240, help="fixed steps simulated per setting (default 240)")
    w.add_argument("--blades", type=_blade_count, default=4096, help="number of blades (default 4096)")
    w.add_argument("--size", type=_size, default=(240, 180), help="size of each cell WxH (default 240x180)")
    w.add_argument("--preset", choices=["default", "cis565", "meadow"], default="default", help="scene preset")
    w.add_argument("--seed", type=_non_negative, default=0, help="random seed, an integer >= 0")
    w.add_argument("--no-progress", action="store_true", help="no progress bar")

    b = sub.add_parser("bench", help="benchmark frame, simulation and culling times")
    b.add_argument("--preset", choices=["cis565", "meadow"], default="cis565")
    b.add_argument("--blades", type=_blade_count, nargs="+", default=None,
                   help="blade counts (default: 2^10..2^17 for cis565, 2^16..2^22 for meadow)")
    b.add_argument("--frames", type=_positive, default=30)
    b.add_argument("--size", type=_size, default=None, help="WxH (default: the preset's)")
    b.add_argument("--cull", choices=["on", "off", "both", "each"], default="on")
    b.add_argument("--occlusion", choices=["on", "off", "both"], default="on",
                   help="occlusion culling in the modes that cull: on, off, or both (off, then on, in one run)")
    b.add_argument("--compute-raster", choices=["on", "off", "both"], default="on",
                   help="the compute rasterizer of thin blades: on, off, or both (off, then on, in one run)")
    b.add_argument("--raster-max-px", type=float, nargs="+", default=None, metavar="PX",
                   help="run the compute-rasterizer rows once per compute_raster_max_px value (pixels, 0..16; "
                        "default: the params' default)")
    b.add_argument("--matrix", action="store_true",
                   help="the defaults (occlusion culling and compute rasterizer 'auto') against every fixed "
                        "combination, interleaved in one run (ignores --cull, --occlusion, --compute-raster, --frames); "
                        "writes JSON (--json, default bench-matrix-PRESET.json)")
    b.add_argument("--rounds", type=_positive, default=3, help="--matrix: rounds over the five settings")
    b.add_argument("--block", type=_positive, default=3, help="--matrix: timed frames per setting per round")
    b.add_argument("--no-horizon", action="store_true",
                   help="meadow preset: the square field of before (no grass to the horizon)")
    b.add_argument("--json", default=None, help="write the report to this JSON file (a missing folder is created)")
    b.add_argument("--no-progress", action="store_true")
    p.subcommands = {"snapshot": s, "bench": b, "html": h, "sweep": w}
    return p


def _subparser(parser, name):
    """The parser of subcommand ``name`` (build_parser keeps them: argparse offers no public lookup)."""
    return getattr(parser, "subcommands", {}).get(name, parser)


def _make_folder(parser, path, what):
    """Create the folder of ``path`` when it is missing; an argument error when it cannot be."""
    if path is None:
        return
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        parser.error(f"argument {what}: {path!r} is a folder; give a file name")
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as err:
        parser.error(f"argument {what}: cannot create the folder {folder!r}: {err.strerror or err}")
    if not os.access(folder, os.W_OK):
        parser.error(f"argument {what}: the folder {folder!r} is not writable")


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    sub = _subparser(parser, args.command)
    if args.command in ("snapshot", "sweep"):
        _make_folder(sub, args.out, "out")
    if args.command == "sweep":
        if len(args.vary) > 2 or len({name for axis in args.vary for name in axis}) < len(args.vary):
            sub.error("argument --vary: give one parameter (a row) or two different ones (a grid); got "
                      + ", ".join(name for axis in args.vary for name in axis))
    elif args.command == "bench":
        _make_folder(sub, args.json, "--json")

    from ..errors import BladeCountError, NoGPUAdapterError

    try:
        from ..gpu.field import check_blade_count_fits

        if args.command == "html":
            return _html(args)
        for count in ([args.blades] if args.command in ("snapshot", "sweep") else args.blades or ()):
            check_blade_count_fits(count)  # the GPU's buffer limit, before any blade is made
        if args.command == "snapshot":
            return _snapshot(args)
        if args.command == "sweep":
            return _sweep(args)
        return _bench(args)
    except NoGPUAdapterError as err:
        print(f"{sub.prog}: error: {err}", file=sys.stderr)
        return 2
    except BladeCountError as err:
        sub.error(f"argument --blades: {err}")
    except OSError as err:  # e.g. the image cannot be written
        name = f" {err.filename!r}" if err.filename else ""
        sub.error(f"cannot write{name}: {err.strerror or err}")
    except ValueError as err:
        sub.error(str(err))


def write_image(path, img):
    """Write an (h, w, 4) uint8 RGBA picture; the format follows the extension
    (.png lossless with alpha; .jpg/.jpeg RGB at :data:`JPEG_QUALITY`)."""
    import imageio.v3 as iio

    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext == ".png":
        iio.imwrite(path, img, extension=".png")
    elif ext in (".jpg", ".jpeg"):
        iio.imwrite(path, img[..., :3], extension=ext, quality=JPEG_QUALITY)
    else:
        raise GrassValueError(f"path must end in {', '.join(IMAGE_EXTENSIONS)}; got {os.fspath(path)!r}")
    return os.fspath(path)


def _snapshot(args):
    from ..core.params import GrassParams
    from ..gpu.scene import GrassScene

    params = GrassParams()
    if args.wind is not None:
        params.wind_strength = args.wind
    if args.preset == "default":
        scene = _default_scene(args, params)
    else:
        scene = GrassScene.preset(args.preset, blades=args.blades, size=args.size, params=params, seed=args.seed,
                                  horizon=not args.no_horizon)
    scene.step(args.steps)
    path = write_image(args.out, scene.render_at(args.size))  # anti-aliased (see GrassScene.render_at)
    print(f"wrote {path} ({args.size[0]}x{args.size[1]}, {args.blades} blades, {args.steps} steps, "
          f"{scene.visible_count()} drawn)")
    return 0


def _default_scene(args, params):
    from ..core.blades import Blades
    from ..gpu.scene import GrassScene

    return GrassScene(Blades.on_plane(args.blades, seed=args.seed), size=args.size, params=params)


def _html(args):
    from ..core.blades import Blades
    from ..core.params import GrassParams
    from .html_export import save_html

    params = GrassParams()
    if args.wind is not None:
        params.wind_strength = args.wind
    camera = None
    if args.preset == "default":
        blades, size = Blades.on_plane(args.blades, seed=args.seed), args.size or (960, 540)
    else:
        from ..core.presets import preset_field

        blades, preset_size, view = preset_field(args.preset, args.blades, seed=args.seed)
        size = args.size or preset_size
        camera = {k: (list(map(float, view[k])) if k in ("position", "target") else float(view[k]))
                  for k in ("position", "target", "fov_deg", "near", "far")}
    path = save_html(args.out, blades, params, size=size, camera=camera, playing=not args.paused,
                     still=not args.no_still, title=f"grasswidget meadow ({len(blades)} blades)")
    kb = os.path.getsize(path) / 1024
    print(f"wrote {path} ({kb:.0f} KiB: {size[0]}x{size[1]}, {len(blades)} blades; open it in a browser with "
          "WebGPU, served over http(s) or from a file)")
    return 0


def _sweep(args):
    from .sweep import sweep

    axes = {name: values for axis in args.vary for name, values in axis.items()}
    result = sweep(axes, steps=args.steps, blades=args.blades, preset=None if args.preset == "default" else args.preset,
                   size=args.size, seed=args.seed, progress=not args.no_progress)
    path = result.save(args.out)
    names = list(result.axes)
    print(f"wrote {path} ({result.image.shape[1]}x{result.image.shape[0]}: "
          f"{' x '.join(f'{n} ({len(v)})' for n, v in result.axes.items())}, {result.blades} blades, "
          f"{result.steps} steps)")
    tips, bends = result.data["mean_tip_offset"].reshape(-1), result.data["mean_bend_deg"].reshape(-1)
    drawn = result.data["blades_drawn"].reshape(-1)
    k = 0
    for row in (result.axes[names[0]] if len(names) == 2 else [None]):
        for col in result.axes[names[-1]]:
            where = (f"{names[0]}={row:g}, " if isinstance(row, float) else (f"{names[0]}={row}, " if row is not None else ""))
            where += f"{names[-1]}={col:g}" if isinstance(col, float) else f"{names[-1]}={col}"
            print(f"  {where}: mean tip offset {tips[k]:.4f} m, mean bend {bends[k]:.2f} deg, {drawn[k]} blades drawn")
            k += 1
    return 0


def _bench(args):
    from .benchmark import format_table, run_benchmark, save_json

    blades = args.blades
    if blades is None:
        blades = [1 << k for k in (range(10, 18) if args.preset == "cis565" else range(16, 23))]
    if args.matrix:
        from .benchmark_matrix import format_matrix, run_matrix

        report = run_matrix(args.preset, blades, size=args.size, rounds=args.rounds, block=args.block,
                            progress=not args.no_progress)
        print(format_matrix(report))
        path = args.json or f"bench-matrix-{args.preset}.json"
        save_json(report, path)
        print(f"wrote {path}")
        return 0
    report = run_benchmark(args.preset, blades, frames=args.frames, size=args.size, cull=args.cull,
                       progress=not args.no_progress, occlusion=args.occlusion, compute_raster=args.compute_raster,
                       raster_max_px=args.raster_max_px, horizon=not args.no_horizon)
    print(format_table(report))
    if args.json:
        save_json(report, args.json)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
