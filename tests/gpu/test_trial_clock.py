"""What an "auto" switch's trial frame is timed by (grasswidget.gpu.trial_timing.trial_clock): on a GPU
adapter with timestamp queries the GPU time of the frame's passes (grasswidget.gpu.stats.PassTimer), because
a synchronised frame's wall time there is mostly the host's work; the process's CPU time on a CPU adapter.

The timer's bookkeeping (which passes it times, when its reading is None) is checked on any adapter; its
readings against work of known proportions on a GPU adapter only (the GPU machine's suite): lavapipe's
timestamps at a compute pass's beginning and end do not wait for the pass's dispatches once other work
has run on the device (a 12 ms dispatch read as 0.03-0.12 ms after a scene had rendered; 12 ms in a fresh
process), which is one reason the trial uses the CPU time there. The GPU adapter's path of the trial is
checked on lavapipe too, by calling it a GPU adapter for the trial's clock (the renders are lavapipe's all
the same): every trial frame's time is the timer's reading.
"""

import threading

import pytest
import wgpu

import grasswidget as gw
from grasswidget.core.auto_switches import AutoSwitches
from grasswidget.errors import GrassValueError
from grasswidget.gpu import adapter as gpu_adapter
from grasswidget.gpu.adapter import ensure_device, is_cpu_adapter
from grasswidget.gpu.stats import PassTimer
from grasswidget.gpu.trial_timing import switches_of, trial_clock

LOOP = """
@group(0) @binding(0) var<storage, read_write> out: array<f32>;
override ITERATIONS: u32 = 1u;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    var x = f32(id.x);
    for (var i = 0u; i < ITERATIONS; i += 1u) { x = fract(x * 1.0001 + 0.37); }
    out[id.x] = x;
}
"""


@pytest.fixture(scope="module")
def device():
    dev = ensure_device()
    if "timestamp-query" not in dev.features:
        pytest.skip("this device has no timestamp queries")
    return dev


def _loop(device, iterations):
    """A function that encodes one compute pass of 4096 threads, each ``iterations`` steps long, and submits it."""
    module = device.create_shader_module(code=LOOP)
    pipeline = device.create_compute_pipeline(layout="auto", compute={"module": module, "entry_point": "main",
                                                                      "constants": {"ITERATIONS": iterations}})
    buf = device.create_buffer(size=4 * 4096, usage=wgpu.BufferUsage.STORAGE)
    group = device.create_bind_group(layout=pipeline.get_bind_group_layout(0),
                                     entries=[{"binding": 0, "resource": {"buffer": buf}}])

    def run(timestamp_writes=None):
        enc = device.create_command_encoder()
        kwargs = {"timestamp_writes": timestamp_writes} if timestamp_writes else {}
        cp = enc.begin_compute_pass(**kwargs)
        cp.set_pipeline(pipeline)
        cp.set_bind_group(0, group)
        cp.dispatch_workgroups(4096 // 64)
        cp.end()
        device.queue.submit([enc.finish()])

    return run


def _timed(timer, *runs):
    timer.start()
    try:
        for run in runs:
            run()
    finally:
        timer.stop()
    return timer.read_ms()


def test_the_pass_timer_sums_its_threads_passes_in_proportion_to_their_work(device):
    # Work of comparable size (2x the steps), so that a sum of both passes (3 parts) stands apart from the
    # last pass alone (2 parts) or the first (1 part). The least of 5 readings: other processes' work on a
    # shared GPU (the suite's other worker) can only lengthen a pass between its timestamps.
    light, heavy = _loop(device, 6400), _loop(device, 12800)
    timer = PassTimer(device, capacity=4)
    for run in (light, heavy):  # compiled and run once
        run()
    light_ms = min(_timed(timer, light) for _ in range(5))
    heavy_ms = min(_timed(timer, heavy) for _ in range(5))
    both_ms = min(_timed(timer, light, heavy) for _ in range(5))
    assert timer.used == 2 and timer.missed == 0
    assert light_ms > 0 and heavy_ms > 0 and both_ms > 0
    if not is_cpu_adapter():  # see the module docstring: lavapipe's pass timestamps
        assert heavy_ms > 1.4 * light_ms, (light_ms, heavy_ms)  # 2x the steps
        assert 0.8 * (light_ms + heavy_ms) <= both_ms <= 2.0 * (light_ms + heavy_ms), (light_ms, heavy_ms, both_ms)

    # another thread's passes are not the timer's
    timer.start()
    try:
        worker = threading.Thread(target=heavy)
        worker.start()
        worker.join()
        assert timer.used == 0
        light()
    finally:
        timer.stop()
    assert timer.used == 1 and timer.read_ms() > 0
    light()  # stopped: not timed
    assert timer.used == 1


def test_a_pass_the_timer_could_not_time_makes_its_reading_none(device):
    light = _loop(device, 50)
    timer = PassTimer(device, capacity=2)
    assert _timed(timer) is None  # nothing begun
    assert _timed(timer, light, light, light) is None and timer.missed == 1  # over its capacity
    own = device.create_query_set(type="timestamp", count=2)
    writes = {"query_set": own, "beginning_of_pass_write_index": 0, "end_of_pass_write_index": 1}
    assert _timed(timer, light, lambda: light(writes)) is None  # a pass with timestamp writes of its own
    assert _timed(timer, light) > 0  # and the next start counts afresh
    with pytest.raises(GrassValueError, match="capacity must be an integer >= 1; got 0"):
        PassTimer(device, capacity=0)


def test_a_gpu_adapters_trial_frames_are_timed_by_their_passes(device, monkeypatch):
    scene = gw.GrassScene.preset("cis565", blades=4096, size=(160, 120), seed=1)
    try:
        assert trial_clock() == ("cpu" if is_cpu_adapter() else "gpu")
        monkeypatch.setattr(gpu_adapter, "is_cpu_adapter", lambda: False)  # the trial's clock only: see above
        assert trial_clock() == "gpu"
        recorded, read = [], []
        record, read_ms = AutoSwitches.record, PassTimer.read_ms

        def spy_record(self, ms, counts):
            recorded.append(ms)
            return record(self, ms, counts)

        def spy_read(self):
            read.append(read_ms(self))
            return read[-1]

        monkeypatch.setattr(AutoSwitches, "record", spy_record)
        monkeypatch.setattr(PassTimer, "read_ms", spy_read)
        state = switches_of(scene.field)
        for _ in range(8):
            scene.render()
        assert state.trial_frames_run >= 4 and len(recorded) >= 4, (state.trial_frames_run, recorded)
        # every trial frame's time is its passes' GPU time (all of them timed: none None)
        assert recorded == read and all(ms > 0 for ms in recorded), (recorded, read)
    finally:
        scene.release()
