"""Benchmark: the cost of one simulation step with 1, 16, 256 and 1024 sphere colliders.

A field of ``--blades`` blades on a ``--size`` m square (meadow grass, h 0.5-1.0 m),
``K`` balls of radius 0.3-0.7 m resting in the grass (centre 0.8 R above the ground)
at seeded random places, the same first K balls for every K. Per K, one sample is
``--steps`` steps in one ``field.step()`` dispatch, GPU-synchronised (a small
readback waits for the queue); the colliders' upload happens before the timing (the
grid is built once per K, when the balls change). The K values are interleaved,
round after round, in one process (common.interleave), so that a noisy machine loads them alike; the
ratios to one ball are of the medians.

Also per K: the grid (cells, list entries), the spheres a blade tests on average
(its cell's list) and the share of blades the balls touch after the run (collision
strength > 0), so that the cost can be read against the work.

Usage (repository root)::

    python benchmarks/colliders.py --blades 65536
    python benchmarks/colliders.py --blades 1048576 --steps 128 --rounds 20 --no-grid

(On the GPU machine a step of 2^20 blades should take well under a millisecond, so a sample of 128
steps in one dispatch keeps the readback that ends each sample to a few percent of it.
The benchmark imports only the core and GPU layers: no anywidget, no notebook.)

``--no-grid`` also times each K with a one-cell grid (every blade tests every ball), interleaved.

Prints a table and writes benchmarks/results/colliders-<machine>-<date>.json (or ``--out``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

common.use_this_checkout()

import grasswidget as gw  # noqa: E402
from grasswidget.core.collider_grid import MAX_GRID_CELLS, build_collider_grid, root_bounds  # noqa: E402
from grasswidget.core.reference import COLLIDER_REACH  # noqa: E402

BALLS = (1, 16, 256, 1024)


def crowd(k_max, size, seed=7):
    """(k_max, 4) balls resting in the grass at seeded random places of the field."""
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.3, 0.7, k_max)
    xz = rng.uniform(-0.5 * size + 0.5, 0.5 * size - 0.5, (k_max, 2))
    return np.column_stack([xz[:, 0], 0.8 * r, xz[:, 1], r])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blades", type=int, default=1 << 16)
    ap.add_argument("--size", type=float, default=64.0, help="side of the field, metres (default 64)")
    ap.add_argument("--balls", type=int, nargs="+", default=list(BALLS))
    ap.add_argument("--steps", type=int, default=4, help="steps per timed sample (one dispatch)")
    ap.add_argument("--rounds", type=int, default=12, help="interleaved rounds (samples per K)")
    common.add_out_argument(ap, "colliders")
    ap.add_argument("--no-grid", action="store_true",
                    help="also time every K with a one-cell grid (each blade tests every ball: the paper's loop)")
    args = ap.parse_args(argv)

    from grasswidget.gpu.adapter import ensure_device
    from grasswidget.gpu.compute import sync_buffer

    device = ensure_device()
    blades = gw.Blades.on_plane(args.blades, size=args.size, seed=1, height=(0.5, 1.0), width=(0.02, 0.04))
    field = gw.GrassField(blades, gw.GrassParams(wind_strength=4.0))
    balls = crowd(max(args.balls), args.size)
    small = field.collision_buffer  # any buffer: its readback waits for the queue

    def sync():
        device.queue.read_buffer(sync_buffer(small), 0, 4)

    def run(k, cells=None):
        field.simulation.max_grid_cells = cells or MAX_GRID_CELLS
        field.colliders.set_array(balls[:k])
        field.step(1)  # uploads the colliders and their grid (outside the timing)
        sync()
        t = time.perf_counter()
        field.step(args.steps)
        sync()
        return (time.perf_counter() - t) * 1000.0 / args.steps

    measures = {}
    for k in args.balls:
        measures[k] = lambda k=k: run(k)
        if args.no_grid:
            measures[k, "no grid"] = lambda k=k: run(k, cells=1)
    timed = common.interleave(measures, args.rounds, warmup=1)
    samples = {k: timed[k] for k in args.balls}
    looped = {k: timed.get((k, "no grid"), []) for k in args.balls}

    rows = []
    bounds, h_max = root_bounds(blades.v0), float(blades.height.max())
    base = common.median(samples[args.balls[0]])
    base_p10 = float(np.percentile(samples[args.balls[0]], 10))
    for k in args.balls:
        grid = build_collider_grid(balls[:k], bounds, h_max)
        tested = grid.cell_count[grid.cell_of(blades.v0)].mean()
        field.reset()
        field.colliders.set_array(balls[:k])
        field.step(30)
        touched = float((field.read_state()["collision"] > 0).mean())
        med = common.median(samples[k])
        rows.append(dict(balls=k, step_ms_median=med, step_ms_p10=float(np.percentile(samples[k], 10)),
                         step_ms_p90=float(np.percentile(samples[k], 90)), ratio_to_first=med / base,
                         ratio_to_first_p10=float(np.percentile(samples[k], 10)) / base_p10,
                         grid_cells=[grid.nx, grid.nz], grid_entries=int(len(grid.items)),
                         spheres_tested_per_blade=float(tested), blades_touched=touched))
        if args.no_grid:
            rows[-1]["no_grid_step_ms_median"] = common.median(looped[k])
            rows[-1]["no_grid_ratio_to_first"] = common.median(looped[k]) / base
    adapter = device.adapter.summary
    report = dict(
        benchmark="colliders", blades=args.blades, size_m=args.size, steps_per_sample=args.steps,
        rounds=args.rounds, collider_reach_heights=COLLIDER_REACH, blade_height_m=[0.5, 1.0],
        ball_radius_m=[0.3, 0.7], rows=rows,
        note="ratios of medians (and of 10th percentiles, less moved by other processes) to the first K, "
             "measured interleaved in one process",
    )
    print(f"{adapter} - {args.blades} blades on {args.size:g} m, {args.steps} steps/sample, "
          f"{args.rounds} interleaved rounds")
    print(f"{'balls':>6} {'ms/step':>9} {'p10':>7} {'p90':>7} {'x first':>8} {'x p10':>6} {'cells':>7} {'entries':>8} "
          f"{'tested':>7} {'touched':>8}")
    for r in rows:
        print(f"{r['balls']:>6} {r['step_ms_median']:>9.3f} {r['step_ms_p10']:>7.3f} {r['step_ms_p90']:>7.3f} "
              f"{r['ratio_to_first']:>8.2f} {r['ratio_to_first_p10']:>6.2f} {r['grid_cells'][0] * r['grid_cells'][1]:>7} {r['grid_entries']:>8} "
              f"{r['spheres_tested_per_blade']:>7.2f} {r['blades_touched']:>8.1%}"
              + (f"   no grid: {r['no_grid_step_ms_median']:.3f} ms, x{r['no_grid_ratio_to_first']:.2f}"
                 if args.no_grid else ""))
    common.save("colliders", report, adapter, args.out)
    return report


if __name__ == "__main__":
    main()
