"""Blade counts are checked against host memory and the adapter's buffers before
anything is allocated, with an error that names count, the limit and the memory."""

import time
import tracemalloc

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import memory


def _fake_meminfo(tmp_path, monkeypatch, available_kib):
    path = tmp_path / "meminfo"
    path.write_text(f"MemTotal:       99999999 kB\nMemFree:          12345 kB\nMemAvailable:   {available_kib} kB\n")
    monkeypatch.setattr(memory, "MEMINFO", str(path))
    monkeypatch.setattr(memory, "CGROUP_FILES", ())


def test_numpy_bytes_per_blade_bounds_the_measured_peak():
    """The constant the check uses is an upper bound of what making blades really
    takes (tracemalloc), and not a wild overestimate."""
    n = 100_000
    makers = {
        "on_plane": lambda: gw.Blades.on_plane(n),
        "on_plane + packed": lambda: (lambda b: (b, b.packed()))(gw.Blades.on_plane(n)),
        "on_heightmap": lambda: gw.Blades.on_heightmap(np.zeros((64, 64)), 10.0, n),
        "on_mesh": lambda: gw.Blades.on_mesh((np.float32([[0, 0, 0], [1, 0, 0], [0, 0, 1]]), np.int32([0, 2, 1])),
                                             count=n),
    }
    peaks = {}
    for name, make in makers.items():
        tracemalloc.start()
        result = make()
        peaks[name] = tracemalloc.get_traced_memory()[1] / n
        tracemalloc.stop()
        del result
    assert max(peaks.values()) <= memory.NUMPY_BYTES_PER_BLADE, peaks
    assert max(peaks.values()) >= 0.5 * memory.NUMPY_BYTES_PER_BLADE, peaks


def test_available_memory_reads_meminfo_and_a_container_limit(tmp_path, monkeypatch):
    _fake_meminfo(tmp_path, monkeypatch, 2_000_000)
    assert memory.available_memory() == (2_000_000 * 1024, "MemAvailable in /proc/meminfo")
    # a cgroup (container) limit lower than that wins
    limit, usage = tmp_path / "memory.max", tmp_path / "memory.current"
    limit.write_text("1073741824\n")
    usage.write_text("73741824\n")
    monkeypatch.setattr(memory, "CGROUP_FILES", ((str(limit), str(usage)),))
    avail, source = memory.available_memory()
    assert avail == 1_000_000_000 and "container" in source
    limit.write_text("max\n")  # no limit
    assert memory.available_memory()[0] == 2_000_000 * 1024
    # the real machine: a positive figure no larger than the physical memory
    monkeypatch.setattr(memory, "MEMINFO", "/proc/meminfo")
    real, _ = memory.available_memory()
    import os

    assert 0 < real <= os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def test_a_billion_blades_raise_at_once_naming_count_limit_and_memory():
    t0 = time.perf_counter()
    tracemalloc.start()
    with pytest.raises(ValueError) as info:
        gw.Blades.on_plane(10**12)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert time.perf_counter() - t0 < 1.0
    assert peak < 1 << 20  # nothing was allocated
    err = info.value
    assert isinstance(err, gw.BladeCountError) and err.count == 10**12
    text = str(err)
    assert "count=1,000,000,000,000" in text
    assert f"at most {err.limit:,}" in text
    assert memory.format_bytes(10**12 * memory.NUMPY_BYTES_PER_BLADE) in text  # the memory it would take
    assert memory.format_bytes(err.available_bytes) in text  # the memory there is
    # the limit is consistent: limit blades fit, limit + 1 do not
    assert err.limit * memory.NUMPY_BYTES_PER_BLADE <= err.available_bytes
    assert (err.limit + 1) * memory.NUMPY_BYTES_PER_BLADE > err.available_bytes


def test_every_generator_checks_the_count(tmp_path, monkeypatch):
    _fake_meminfo(tmp_path, monkeypatch, 1000)  # 1000 KiB: 3555 blades at 288 bytes
    limit = 1000 * 1024 // memory.NUMPY_BYTES_PER_BLADE
    assert len(gw.Blades.on_plane(limit)) == limit
    tri = (np.float32([[0, 0, 0], [1, 0, 0], [0, 0, 1]]), np.int32([0, 2, 1]))
    for make in (
        lambda: gw.Blades.on_plane(limit + 1),
        lambda: gw.Blades.on_heightmap(np.zeros((4, 4)), 5.0, limit + 1),
        lambda: gw.Blades.on_mesh(tri, count=limit + 1),
        lambda: gw.Blades.on_mesh(tri, density=2 * (limit + 1)),  # the triangle's area is 0.5 m^2
    ):
        with pytest.raises(gw.BladeCountError, match=rf"count={limit + 1:,} .* at most {limit:,}") as info:
            make()
        assert info.value.limit == limit and info.value.where == "host memory"


def test_gpu_limit_arithmetic():
    # the constants are the GPU layer's real sizes
    from grasswidget.core.blades import BLADE_BYTES

    assert memory.GPU_STATE_BYTES_PER_BLADE == BLADE_BYTES
    field = gw.GrassField(gw.Blades.on_plane(64))
    try:
        assert field.bytes_per_blade == (memory.GPU_STATE_BYTES_PER_BLADE + memory.GPU_INDEX_BYTES_PER_BLADE
                                         + memory.GPU_COLLISION_BYTES_PER_BLADE)
    finally:
        field.release()
    limits = {"max-storage-buffer-binding-size": 128 << 20, "max-buffer-size": 1 << 31}
    assert memory.max_blades_for_gpu(limits) == (128 << 20) // 64 == 2_097_152
    assert memory.check_gpu_blade_count(2_097_152, limits) == 2_097_152
    with pytest.raises(gw.BladeCountError) as info:
        memory.check_gpu_blade_count(2_097_153, limits, "a test adapter")
    text = str(info.value)
    assert "count=2,097,153" in text and "at most 2,097,152" in text and "128 MiB" in text
    assert "a test adapter" in text and "max_storage_buffer_binding_size 134217728" in text
    # max_buffer_size binds when it is the smaller one
    assert memory.max_blades_for_gpu({"max-storage-buffer-binding-size": 1 << 30, "max-buffer-size": 64 << 20}) \
        == (64 << 20) // 64


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


def test_widget_blade_count_uses_the_same_check(widget):
    old = widget.blade_count
    with pytest.raises(gw.BladeCountError, match=r"blades: count=1,000,000,000,000 .* at most"):
        widget.set_blades(10**12)
    assert widget.blade_count == old and widget.scene is not None
    # the blade control: the error shows in the message line and the control goes back
    control = widget.panel.blade_control
    control.choose(10**12)  # as if the control offered it: more blades than measured for, so it asks
    assert control.pending == 10**12 and widget.blade_count == old
    control.confirm()  # Apply
    assert "count=1,000,000,000,000" in widget.message_line.value
    assert widget.blade_slider.value == old and widget.blade_count == old
    # the slider never offers more than fits
    from grasswidget.gpu.field import max_blade_count

    fresh = gw.GrassWidget(blades=64, size=(160, 120))
    try:
        assert max(v for _label, v in fresh.blade_slider.options) <= max_blade_count()
    finally:
        fresh.close()
