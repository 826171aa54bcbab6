"""Command line: ``grasswidget snapshot ...`` and ``grasswidget bench ...``."""

from __future__ import annotations

import argparse
import sys


def _size(text):
    from .scene import parse_size

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


def build_parser():
    p = argparse.ArgumentParser(prog="grasswidget", description="Physically animated grass on the GPU.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("snapshot", help="simulate a field and write a PNG")
    s.add_argument("out", help="output PNG path")
    s.add_argument("--blades", type=_positive, default=65536, help="number of blades (default 65536)")
    s.add_argument("--size", type=_size, default=(1280, 720), help="image size WxH (default 1280x720)")
    s.add_argument("--steps", type=_non_negative, default=240, help="fixed simulation steps before the picture (default 240)")
    s.add_argument("--preset", choices=["default", "cis565", "meadow"], default="default", help="scene preset")
    s.add_argument("--wind", type=float, default=None, help="wind strength in m/s^2 (default: GrassParams default)")
    s.add_argument("--seed", type=int, default=0)

    b = sub.add_parser("bench", help="benchmark frame, simulation and culling times")
    b.add_argument("--preset", choices=["cis565", "meadow"], default="cis565")
    b.add_argument("--blades", type=_positive, nargs="+", default=None,
                   help="blade counts (default: 2^10..2^17 for cis565, 2^16..2^22 for meadow)")
    b.add_argument("--frames", type=_positive, default=30)
    b.add_argument("--size", type=_size, default=None, help="WxH (default: the preset's)")
    b.add_argument("--cull", choices=["on", "off", "each"], default="on")
    b.add_argument("--json", default=None, help="write the report to this JSON file")
    b.add_argument("--no-progress", action="store_true")
    return p


def main(argv=None):
    args = build_parser().parse_args(argv)
    from .errors import NoGPUAdapterError

    try:
        if args.command == "snapshot":
            return _snapshot(args)
        return _bench(args)
    except NoGPUAdapterError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


def _snapshot(args):
    from . import GrassParams
    from .scene import GrassScene

    params = GrassParams()
    if args.wind is not None:
        params.wind_strength = args.wind
    if args.preset == "default":
        from .blades import Blades

        scene = GrassScene(Blades.on_plane(args.blades, seed=args.seed), size=args.size, params=params)
    else:
        scene = GrassScene.preset(args.preset, blades=args.blades, size=args.size, params=params, seed=args.seed)
    scene.step(args.steps)
    path = scene.save_png(args.out)
    print(f"wrote {path} ({args.size[0]}x{args.size[1]}, {args.blades} blades, {args.steps} steps, "
          f"{scene.visible_count()} drawn)")
    return 0


def _bench(args):
    from .bench import format_table, run_bench, save_json

    blades = args.blades
    if blades is None:
        blades = [1 << k for k in (range(10, 18) if args.preset == "cis565" else range(16, 23))]
    report = run_bench(args.preset, blades, frames=args.frames, size=args.size, cull=args.cull,
                       progress=not args.no_progress)
    print(format_table(report))
    if args.json:
        save_json(report, args.json)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
