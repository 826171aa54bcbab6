"""The GPU layer checks blade counts against the adapter's buffers before allocating anything, and
its buffers are the sizes per blade that grasswidget.core.memory counts with."""

import time
import tracemalloc

import pytest

import grasswidget as gw
from grasswidget.core import memory


def test_a_fields_buffers_are_the_bytes_per_blade_memory_counts():
    field = gw.GrassField(gw.Blades.on_plane(64))
    try:
        assert field.bytes_per_blade == (memory.GPU_STATE_BYTES_PER_BLADE + memory.GPU_INDEX_BYTES_PER_BLADE
                                         + memory.GPU_COLLISION_BYTES_PER_BLADE)
    finally:
        field.release()


def test_scene_checks_the_adapter_before_making_blades():
    from grasswidget.gpu.adapter import ensure_device

    device = ensure_device()
    limit = memory.max_blades_for_gpu(device.limits)
    too_many = limit + 1
    if too_many * memory.NUMPY_BYTES_PER_BLADE > (memory.available_memory()[0] or 0):
        pytest.skip("this machine's memory is smaller than the adapter's buffer limit")
    scene_class = gw.GrassScene  # (imports the module before measuring)
    t0 = time.perf_counter()
    tracemalloc.start()
    with pytest.raises(gw.BladeLimitError) as info:
        scene_class(too_many)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert time.perf_counter() - t0 < 1.0
    assert peak < 4 << 20  # refused before the blades were made (they would take ~288 bytes each)
    assert isinstance(info.value, ValueError) and info.value.limit == limit
    assert f"count={too_many:,}" in str(info.value) and f"at most {limit:,}" in str(info.value)
    with pytest.raises(gw.BladeLimitError):
        gw.GrassScene.preset("cis565", blades=too_many)
