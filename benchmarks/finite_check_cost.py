"""Benchmark: what the simulation's finite check (``validate_finite``, issue 37 item 5) costs a step.

Two fields of the same ``--blades`` blades in one process: the stock simulation, and the same
simulation with ``validate_finite`` replaced (through ``GrassField.set_function_overrides``) by
one that passes every blade through unchecked, i.e. the step as it was before the check. One
sample is ``--steps`` steps in one ``field.step()``, GPU-synchronised (a 4-byte readback waits for
the queue). The two are interleaved, round after round (common.interleave), so that a noisy machine loads them alike;
the ratio is of the medians. The default wave wind, no colliders.

Usage (repository root)::

    python benchmarks/finite_check_cost.py --blades 65536

Prints the figures and writes benchmarks/results/finite_check_cost-<machine>-<date>.json (or ``--out``). Imports only the core and
GPU layers.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

common.use_this_checkout()

#: validate_finite without the check: what a step did before it.
UNCHECKED = """fn validate_finite(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32, eta: f32) -> Settled {
    return Settled(v1, v2, eta, false);
}
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blades", type=int, default=65536)
    parser.add_argument("--steps", type=int, default=32)
    parser.add_argument("--rounds", type=int, default=15)
    common.add_out_argument(parser, "finite_check_cost")
    args = parser.parse_args(argv)

    import grasswidget as gw
    from grasswidget.core.wgsl_overrides import FunctionOverrides
    from grasswidget.gpu.adapter import ensure_device
    from grasswidget.gpu.compute import sync_buffer

    device = ensure_device()
    blades = gw.Blades.on_plane(args.blades, size=40.0, seed=5)
    fields = {"checked": gw.GrassField(blades), "unchecked": gw.GrassField(blades)}
    fields["unchecked"].set_function_overrides(FunctionOverrides(UNCHECKED, ("validate_finite",), "benchmark"))

    def sample(field):
        field.step(args.steps)
        device.queue.read_buffer(sync_buffer(field.collision_buffer), 0, 4)
        t = time.perf_counter()
        field.step(args.steps)
        device.queue.read_buffer(sync_buffer(field.collision_buffer), 0, 4)
        return (time.perf_counter() - t) * 1000.0 / args.steps

    times = common.interleave({name: (lambda f=field: sample(f)) for name, field in fields.items()}, args.rounds)
    med = {name: common.median(v) for name, v in times.items()}
    info = dict(device.adapter.info)
    info["summary"] = device.adapter.summary
    result = {
        "benchmark": "finite_check_cost",
        "blades": args.blades, "steps_per_sample": args.steps, "rounds": args.rounds,
        "ms_per_step_median": med,
        "ms_per_step_samples": times,
        "ratio_checked_to_unchecked": med["checked"] / med["unchecked"],
        "state_finite": {name: bool(all(__import__("numpy").isfinite(f.read_state()[k]).all() for k in ("v1", "v2")))
                         for name, f in fields.items()},
    }
    print(f"{args.blades} blades, {args.steps} steps a sample, {args.rounds} rounds: "
          f"checked {med['checked']:.3f} ms/step, unchecked (before) {med['unchecked']:.3f} ms/step, "
          f"ratio {result['ratio_checked_to_unchecked']:.3f}")
    common.save("finite_check_cost", result, info, args.out)
    for field in fields.values():
        field.release()
    return result


if __name__ == "__main__":
    main()
