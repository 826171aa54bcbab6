"""Benchmark: what the simulation's finite check (``validate_finite``, issue 37 item 5) costs a step.

Two fields of the same ``--blades`` blades in one process: the stock simulation, and the same
simulation with ``validate_finite`` replaced (through ``GrassField.set_function_overrides``) by
one that passes every blade through unchecked, i.e. the step as it was before the check. One
sample is ``--steps`` steps in one ``field.step()``, GPU-synchronised (a 4-byte readback waits for
the queue). The two are interleaved, round after round, so that a noisy machine loads them alike;
the ratio is of the medians. The default wave wind, no colliders.

Usage (repository root)::

    python benchmarks/finite_check_cost.py --blades 65536 --out benchmarks/finite_check_cost_lavapipe.json

Prints the figures and writes the JSON (machine, adapter, figures). Imports only the core and
GPU layers.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

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
    parser.add_argument("--out", type=Path, default=None)
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

    for field in fields.values():  # compile and warm up
        sample(field)
    times = {name: [] for name in fields}
    for _ in range(args.rounds):
        for name, field in fields.items():
            times[name].append(sample(field))
    med = {name: statistics.median(v) for name, v in times.items()}
    info = device.adapter.info if hasattr(device, "adapter") else {}
    result = {
        "benchmark": "finite_check_cost",
        "machine": platform.node(), "python": platform.python_version(),
        "adapter": {k: info.get(k) for k in ("device", "vendor", "adapter_type", "backend_type")} if info else None,
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
    if args.out:
        args.out.write_text(json.dumps(result, indent=1) + "\n")
    for field in fields.values():
        field.release()
    return result


if __name__ == "__main__":
    main()
