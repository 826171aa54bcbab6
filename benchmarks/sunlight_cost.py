"""What the sunlight (GrassParams.shadows) costs a frame, shadows off and on interleaved in one run.

    python benchmarks/sunlight_cost.py [--views live,cis565] [--rounds 5] [--frames 8] [--out PATH]
    python benchmarks/sunlight_cost.py --views meadow --blades 1048576,16777216 --size 1920x1080

One process, one GrassScene per view; each round renders ``--frames`` frames with the shadows
off, then on, then on again, then off (ABBA), a ball in the field; the per-round ratio
on / off of the median frame is taken and its median over the rounds reported. A frame is one
fixed step and one render with its pixel readback (what the kernel view streams), timed as
wall ms and as the process' CPU ms (on lavapipe the rendering threads are the process': CPU ms
moves less than wall time when other processes load the machine). On a GPU the readback
waits for the GPU, so wall ms is the frame's time.

Views:

- ``live``: the widget's default view (4096 blades, 640 x 480, the default camera);
- ``cis565``: the course scene (2^13 blades, 640 x 480; ``GrassScene.preset("cis565")``);
- ``meadow``: the meadow preset at ``--size`` with each of ``--blades``.

``--parts``: the grass layer with the roots and the balls' shadows apart (see ``measure_parts``).

Writes benchmarks/results/sunlight_cost-<machine>-<date>.json (or ``--out``): every round's numbers, the
medians and ratios.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)


def _frames(scene, frames):
    """Median wall and CPU ms of ``frames`` frames (one step and one render with its readback)."""

    def frame():
        scene.step(1)
        scene.render()

    times = common.time_frames(frame, frames, warmup=0)
    return common.median(times["wall_ms"]), common.median(times["cpu_ms"])


def _scene(view, blades, size):
    import grasswidget as gw

    if view == "live":
        scene = gw.GrassScene(gw.Blades.on_plane(4096, seed=0), size=(640, 480))
    elif view == "cis565":
        scene = gw.GrassScene.preset("cis565", size=(640, 480))
    else:
        scene = gw.GrassScene.preset("meadow", blades=blades, size=size)
    v0 = scene.field.blades.v0
    centre = 0.5 * (v0.min(axis=0) + v0.max(axis=0))
    radius = 0.6
    scene.colliders = [gw.SphereCollider(center=(float(centre[0]), float(v0[:, 1].min()) + radius,
                                                 float(centre[2])), radius=radius)]
    return scene


def measure(view, blades, size, rounds, frames):
    scene = _scene(view, blades, size)
    scene.params.shadows = True
    _frames(scene, 3)  # both pipelines built, caches warm
    scene.params.shadows = False
    _frames(scene, 3)
    out = {"view": view, "blades": len(scene.field.blades), "size": list(scene.size), "rounds": []}
    for _ in range(rounds):
        got = {False: [], True: []}
        for on in (False, True, True, False):
            scene.params.shadows = on
            got[on].append(_frames(scene, frames))
        off = [statistics.mean(x[k] for x in got[False]) for k in (0, 1)]
        on = [statistics.mean(x[k] for x in got[True]) for k in (0, 1)]
        out["rounds"].append({"off_wall_ms": off[0], "on_wall_ms": on[0], "off_cpu_ms": off[1], "on_cpu_ms": on[1],
                              "ratio_wall": on[0] / off[0], "ratio_cpu": on[1] / off[1]})
    scene.release()
    for key in ("off_wall_ms", "on_wall_ms", "off_cpu_ms", "on_cpu_ms", "ratio_wall", "ratio_cpu"):
        out[key] = common.median(r[key] for r in out["rounds"])
    return out


def measure_parts(view, blades, size, rounds, frames):
    """The balls' share apart: a second scene whose shaders loop over no ball (the template's
    ``max_shadow_balls`` 0; the rest of the sunlight as it is). Each scene is timed off and on
    (ABBA) in turns; the grass layer with the roots costs the second scene's on - off, the balls
    the first's on - off less that (frames of two scenes are not compared with each other)."""
    from grasswidget.gpu import wgsl_templates

    full = _scene(view, blades, size)
    for on in (True, False):
        full.params.shadows = on
        _frames(full, 3)
    real = wgsl_templates.template_vars
    wgsl_templates.template_vars = lambda: {**real(), "max_shadow_balls": 0}
    try:
        no_balls = _scene(view, blades, size)
        for on in (True, False):
            no_balls.params.shadows = on
            _frames(no_balls, 3)  # its pipelines built with the loop over no ball
    finally:
        wgsl_templates.template_vars = real
    scenes = {"all": full, "no_balls": no_balls}
    out = {"view": view, "blades": len(full.field.blades), "size": list(full.size), "rounds": []}
    for _ in range(rounds):
        row = {}
        for name, scene in scenes.items():
            got = {False: [], True: []}
            for on in (False, True, True, False):
                scene.params.shadows = on
                got[on].append(_frames(scene, frames))
            for k, suffix in ((0, ""), (1, "_cpu")):
                off, on_ = (statistics.mean(x[k] for x in got[b]) for b in (False, True))
                row[f"{name}_off{suffix}"], row[f"{name}_on{suffix}"] = off, on_
                row[f"{name}_share{suffix}"] = (on_ - off) / off
        for suffix in ("", "_cpu"):
            row[f"grass_and_roots{suffix}"] = row[f"no_balls_share{suffix}"]
            row[f"balls{suffix}"] = row[f"all_share{suffix}"] - row[f"no_balls_share{suffix}"]
        out["rounds"].append(row)
    full.release()
    no_balls.release()
    for key in out["rounds"][0]:
        out[key] = common.median(r[key] for r in out["rounds"])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", default="live,cis565")
    ap.add_argument("--blades", default="1048576", help="meadow: blade counts, comma-separated")
    ap.add_argument("--size", default="1920x1080", help="meadow: WxH")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--parts", action="store_true",
                    help="split the cost: the grass layer and roots vs the balls' shadows (wall ms)")
    common.add_out_argument(ap, "sunlight_cost")
    args = ap.parse_args(argv)
    adapter = common.kernel_adapter()
    size = tuple(int(x) for x in args.size.lower().split("x"))
    results = []
    for view in args.views.split(","):
        counts = [int(b) for b in args.blades.split(",")] if view == "meadow" else [None]
        for n in counts:
            if args.parts:
                r = measure_parts(view, n, size, args.rounds, args.frames)
                results.append(r)
                print(f"{view:7s} {r['blades']:>9,d} blades {r['size'][0]}x{r['size'][1]}: sunlight {100 * r['all_share']:+.1f} % "
                      f"of the frame ({r['all_off']:.1f} ms off), of it the grass layer + roots "
                      f"{100 * r['grass_and_roots']:+.1f} %, the balls {100 * r['balls']:+.1f} %; in CPU ms: "
                      f"{100 * r['all_share_cpu']:+.1f} %, grass layer + roots {100 * r['grass_and_roots_cpu']:+.1f} %, "
                      f"balls {100 * r['balls_cpu']:+.1f} % (median of {args.rounds} rounds)", flush=True)
                continue
            r = measure(view, n, size, args.rounds, args.frames)
            results.append(r)
            print(f"{view:7s} {r['blades']:>9,d} blades {r['size'][0]}x{r['size'][1]}: off {r['off_wall_ms']:7.2f} ms "
                  f"({r['off_cpu_ms']:7.2f} CPU ms), on {r['on_wall_ms']:7.2f} ms ({r['on_cpu_ms']:7.2f} CPU ms); "
                  f"on/off {r['ratio_wall']:.3f} wall, {r['ratio_cpu']:.3f} CPU (median of {args.rounds} rounds)",
                  flush=True)
    common.save("sunlight_cost_parts" if args.parts else "sunlight_cost",
                {"views": args.views, "rounds": args.rounds, "frames": args.frames, "results": results}, adapter, args.out)


if __name__ == "__main__":
    main()
