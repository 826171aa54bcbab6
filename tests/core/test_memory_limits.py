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
    """How many blades an adapter's buffer limits allow (the GPU layer's real sizes per blade are
    checked in tests/gpu/test_gpu_memory_limits.py)."""
    from grasswidget.core.blades import BLADE_BYTES

    assert memory.GPU_STATE_BYTES_PER_BLADE == BLADE_BYTES
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
