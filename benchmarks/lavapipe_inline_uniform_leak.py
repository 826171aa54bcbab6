"""The smallest wgpu-py script that shows lavapipe's inline-uniform leak (issue 20).

Mesa's lavapipe (seen with 22.3.6, Debian 12's ``mesa-vulkan-drivers``) looks
for uniform-buffer values that a shader's ``if`` / loop conditions read
("inlinable uniforms"). When a pipeline with such a shader is bound, it clones the
shader, folds the current uniform values in, and when that removes at least half
of the shader's instructions it compiles the result as a new variant. In 22.3
nothing frees those variants, and it happens on *every* pipeline bind, so every
dispatch (or draw) costs a fresh compile and keeps its memory. Later Mesa keeps
inlined variants in a cache keyed by the values (not checked here: only 22.3 is
installed on this machine).

This script binds one compute shader whose body sits behind ``if (u.flag != 0)``,
with ``flag = 0``, and dispatches it ``--dispatches`` times, once with the struct
in a uniform buffer and once in a read-only storage buffer (the workaround
grasswidget uses: storage values are never inlined). It prints and saves JSON:
resident memory growth per dispatch (KB) and milliseconds per dispatch for both.

On this project's CPU machine (llvmpipe, LLVM 15; 2 cores shared with other
work): uniform about 91 KB more resident memory and 1.1-2.9 ms per dispatch,
storage 0 KB and 0.2-0.8 ms (3.5-5x faster in each run). NVIDIA's Vulkan driver
has no such pass (the issue's H100 probe kept 0.000 MB per render).

    python benchmarks/lavapipe_inline_uniform_leak.py [--dispatches 300] [--out PATH]
        (default benchmarks/results/inline_uniform_leak-<machine>-<date>.json)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import wgpu

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

SHADER = """
struct Params {{ flag: i32, pad0: i32, pad1: i32, pad2: i32 }};
@group(0) @binding(0) var<{address_space}> u: Params;
@group(0) @binding(1) var<storage, read_write> s_out: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    var x = f32(gid.x);
    if (u.flag != 0) {{
        for (var k = 0; k < 4; k++) {{
            x = sin(x) * cos(x * 3.0) + sqrt(abs(x)) + tan(x * 0.5) + exp(-x * x) + log(1.0 + abs(x));
        }}
    }}
    s_out[gid.x] = x;
}}
"""


def resident_mb() -> float:
    """Resident memory of this process (MB) from /proc/self/statm."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def measure(device, address_space: str, dispatches: int) -> dict:
    """Dispatch the shader with its params in ``address_space`` ("uniform" or
    "storage, read"); RSS growth and time per dispatch after 30 warm-up dispatches."""
    params_usage = wgpu.BufferUsage.UNIFORM if address_space == "uniform" else wgpu.BufferUsage.STORAGE
    params = device.create_buffer(size=16, usage=params_usage | wgpu.BufferUsage.COPY_DST)  # flag = 0
    out = device.create_buffer(size=4 * 64 * 4, usage=wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_SRC)
    layout = device.create_bind_group_layout(entries=[
        {"binding": 0, "visibility": wgpu.ShaderStage.COMPUTE,
         "buffer": {"type": "uniform" if address_space == "uniform" else "read-only-storage"}},
        {"binding": 1, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": {"type": "storage"}},
    ])
    module = device.create_shader_module(code=SHADER.format(address_space=address_space))
    pipeline = device.create_compute_pipeline(
        layout=device.create_pipeline_layout(bind_group_layouts=[layout]),
        compute={"module": module, "entry_point": "main"},
    )
    bind_group = device.create_bind_group(layout=layout, entries=[
        {"binding": 0, "resource": {"buffer": params}}, {"binding": 1, "resource": {"buffer": out}},
    ])

    def run(n):
        for _ in range(n):
            encoder = device.create_command_encoder()
            cpass = encoder.begin_compute_pass()
            cpass.set_pipeline(pipeline)
            cpass.set_bind_group(0, bind_group)
            cpass.dispatch_workgroups(4)
            cpass.end()
            device.queue.submit([encoder.finish()])
        device.queue.read_buffer(out, 0, 4)  # wait for the queue

    run(30)
    before = resident_mb()
    t0 = time.perf_counter()
    run(dispatches)
    seconds = time.perf_counter() - t0
    return {
        "address_space": address_space,
        "dispatches": dispatches,
        "rss_growth_kb_per_dispatch": round((resident_mb() - before) * 1024 / dispatches, 2),
        "ms_per_dispatch": round(1000 * seconds / dispatches, 3),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dispatches", type=int, default=300, help="dispatches per variant (default 300)")
    common.add_out_argument(ap, "inline_uniform_leak")
    args = ap.parse_args(argv)
    if args.dispatches < 1:
        ap.error(f"--dispatches must be >= 1; got {args.dispatches}")
    adapter = wgpu.gpu.request_adapter_sync(power_preference="high-performance")
    device = adapter.request_device_sync()
    result = {
        "wgpu": wgpu.__version__,
        "uniform": measure(device, "uniform", args.dispatches),
        "storage": measure(device, "storage, read", args.dispatches),
    }
    print(json.dumps(result, indent=2))
    common.save("inline_uniform_leak", result, adapter.summary, args.out)
    return result


if __name__ == "__main__":
    main()
