"""The meadow before (square field, ``horizon=False``) and after (grass to the horizon) from
three cameras: the preset's, low near the ground, high looking far (the same three for both,
inside the orbit limits of the field to the horizon). Writes PNGs, a side-by-side sheet and
``shots.json`` (the header of common.py and each picture's camera) into OUT_DIR.

    python benchmarks/horizon_shots.py OUT_DIR [--blades N] [--size WxH] [--steps S]
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)


def cameras(scene):
    """name -> (position, target) inside the scene's orbit limits."""
    from grasswidget.core.orbit_limits import OrbitLimits, clamp_orbit

    limits = OrbitLimits.for_scene(scene, "grass")
    pos = np.array(scene.camera.local.position, np.float64)  # a copy: look() moves the camera later
    home_target = pos + 30.0 * (-np.asarray(scene.camera.world.matrix, np.float64)[:3, 2])
    r0 = 0.5 * (limits.hi[0] - limits.lo[0]) / 1.2
    low_t = np.array([0.0, 0.4, -r0])
    low_p = np.array([0.0, limits.ground_y + limits.clearance + 0.05, r0 * 0.6])
    el = math.radians(20.0)
    high_t = np.array([0.0, 0.0, -r0])
    high_p = high_t + limits.max_distance * 0.98 * np.array([0.0, math.sin(el), math.cos(el)])
    out = {"preset": (pos, home_target)}
    for name, (p, t) in (("low", (low_p, low_t)), ("high", (high_p, high_t))):
        out[name] = clamp_orbit(p, t, limits)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="folder for the PNGs (pictures, not a measured figure: nothing goes to results/)")
    ap.add_argument("--blades", type=int, default=1 << 20)
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--steps", type=int, default=60)
    args = ap.parse_args(argv)
    from grasswidget.gpu.scene import GrassScene, parse_size
    from grasswidget.tools.cli import write_image

    size = parse_size(args.size)
    os.makedirs(args.out, exist_ok=True)
    cams = None
    shots = {}
    for horizon in (True, False):  # the cameras of the field to the horizon (its orbit limits), for both
        scene = GrassScene.preset("meadow", blades=args.blades, size=size, horizon=horizon)
        scene.step(args.steps)
        cams = cams or cameras(scene)
        for name, (p, t) in cams.items():
            scene.look(position=p, target=t)
            path = os.path.join(args.out, f"meadow_{'after' if horizon else 'before'}_{name}.png")
            write_image(path, scene.render_at(size))
            print("wrote", path, "camera", np.round(p, 2), "->", np.round(t, 2), flush=True)
            shots[os.path.basename(path)] = {"position": [float(v) for v in p], "target": [float(v) for v in t]}
        scene.release()
    import imageio.v3 as iio

    rows = []
    for name in cams:
        a, b = (iio.imread(os.path.join(args.out, f"meadow_{k}_{name}.png"))[..., :3] for k in ("before", "after"))
        rows += [np.concatenate([a, np.full((a.shape[0], 8, 3), 255, np.uint8), b], axis=1)]
        rows += [np.full((8, rows[-1].shape[1], 3), 255, np.uint8)]
    iio.imwrite(os.path.join(args.out, "meadow_before_after_side_by_side.png"), np.concatenate(rows[:-1], axis=0))
    from grasswidget.gpu.adapter import adapter_info

    common.save("horizon_shots", {"blades": args.blades, "size": list(size), "steps": args.steps, "shots": shots},
                adapter_info(), os.path.join(args.out, "shots.json"))


if __name__ == "__main__":
    sys.exit(main())
