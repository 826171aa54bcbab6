"""How many blades fit: memory per blade against what the machine and the adapter allow.

Pure core (no GPU import). A blade count is checked here *before* anything is
allocated, so a count that cannot fit raises at once with a message that says
why, instead of growing the process until the system kills it.

- Host memory (NumPy): making blades peaks at :data:`NUMPY_BYTES_PER_BLADE`
  bytes per blade (random numbers in float64, the arrays of :class:`Blades`,
  then the packed copy uploaded to the GPU). That is compared with the memory
  the system still has available (:func:`available_memory`: ``MemAvailable``
  of ``/proc/meminfo``, or the container's cgroup limit when that is lower).
- GPU memory: the blade state is one storage buffer of
  :data:`GPU_STATE_BYTES_PER_BLADE` bytes per blade and the compacted index
  lists one of :data:`GPU_INDEX_BYTES_PER_BLADE`; each must fit the adapter's
  ``max_storage_buffer_binding_size`` and ``max_buffer_size``.
  :func:`check_gpu_blade_count` does the arithmetic; the GPU layer passes the
  limits of the device it has.

Both raise :class:`BladeCountError`, a ``ValueError`` whose message names
``count``, the limit and the memory the count would take.
"""

from __future__ import annotations

import os

from ..errors import BladeCountError, MissingLimitError

__all__ = [
    "BladeCountError",
    "NUMPY_BYTES_PER_BLADE",
    "GPU_STATE_BYTES_PER_BLADE",
    "GPU_INDEX_BYTES_PER_BLADE",
    "GPU_COLLISION_BYTES_PER_BLADE",
    "available_memory",
    "max_blades_for_memory",
    "check_blade_count",
    "max_blades_for_gpu",
    "check_gpu_blade_count",
    "format_bytes",
]

#: Peak host memory (bytes) per blade while blades are made and packed for upload.
#: Measured with tracemalloc (tests/core/test_memory_limits.py checks it stays an upper
#: bound): on_plane 145, on_mesh 216, on_heightmap 256, on_plane + packed() 168.
NUMPY_BYTES_PER_BLADE = 288
#: GPU bytes per blade in the blade-state storage buffer (4 x vec4<f32>).
GPU_STATE_BYTES_PER_BLADE = 64
#: GPU bytes per blade in the compacted index lists (one u32 per LOD class, 4 classes).
GPU_INDEX_BYTES_PER_BLADE = 16
#: GPU bytes per blade of persistent collision strength (one f32).
GPU_COLLISION_BYTES_PER_BLADE = 4

#: Where the kernel reports available memory (a module attribute, so tests can point it elsewhere).
MEMINFO = "/proc/meminfo"
#: cgroup v2 / v1 files that bound a container's memory (limit, usage).
CGROUP_FILES = (
    ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
    ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes"),
)


def format_bytes(n) -> str:
    """A byte count for people: ``'1.5 GiB'``, ``'128 MiB'``, ``'640 bytes'``."""
    n = float(n)
    for unit, size in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.1f} {unit}".replace(".0 ", " ")
    return f"{int(n)} bytes"


def _read_int(path):
    try:
        with open(path) as f:
            text = f.read().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None  # "max" (no limit) gives None


def available_memory():
    """``(bytes, source)``: host memory a new allocation can still get, and where
    that figure comes from; ``(None, "unknown")`` when the system does not say.

    The smaller of ``MemAvailable`` in /proc/meminfo (free plus reclaimable
    caches) and, inside a container, the cgroup's memory limit minus its usage;
    ``os.sysconf`` free pages where /proc/meminfo is missing.
    """
    best, source = None, "unknown"
    try:
        with open(MEMINFO) as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    best, source = int(line.split()[1]) * 1024, "MemAvailable in /proc/meminfo"
                    break
    except (OSError, ValueError, IndexError):
        pass
    if best is None:
        try:
            best = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
            source = "free pages (os.sysconf)"
        except (ValueError, OSError, AttributeError):
            pass
    for limit_file, usage_file in CGROUP_FILES:
        limit, usage = _read_int(limit_file), _read_int(usage_file)
        if limit is not None and usage is not None and limit < (1 << 60):
            room = max(limit - usage, 0)
            if best is None or room < best:
                best, source = room, f"container memory limit ({limit_file})"
            break
    return best, source


def max_blades_for_memory() -> int | None:
    """The most blades whose making fits in the available host memory (None: unknown)."""
    avail, _source = available_memory()
    return None if avail is None else avail // NUMPY_BYTES_PER_BLADE


def _prefix(name):
    return "" if name in (None, "count") else f"{name}: "


def check_blade_count(count, name=None) -> int:
    """Return ``count`` as an int, or raise :class:`BladeCountError` when making that
    many blades would need more host memory than is available. O(1): reads two
    small files, allocates nothing. ``name``, when given, is the caller's parameter
    (e.g. "blades"), named in front of the message."""
    count = int(count)
    avail, source = available_memory()
    need = count * NUMPY_BYTES_PER_BLADE
    if avail is not None and need > avail:
        limit = avail // NUMPY_BYTES_PER_BLADE
        raise BladeCountError(
            f"{_prefix(name)}count={count:,} blades would take {format_bytes(need)} of memory while they are made "
            f"({NUMPY_BYTES_PER_BLADE} bytes per blade), but this machine has {format_bytes(avail)} available "
            f"({source}): {name or 'count'} must be at most {limit:,}",
            count, limit, need, avail, "host memory",
        )
    return count


def _gpu_caps(limits):
    def get(key):
        for k in (key, key.replace("-", "_")):
            if k in limits:
                return int(limits[k])
        return None

    binding = get("max-storage-buffer-binding-size")
    buffer = get("max-buffer-size")
    if binding is None and buffer is None:
        raise MissingLimitError("limits must give max-storage-buffer-binding-size or max-buffer-size")
    cap = min(x for x in (binding, buffer) if x is not None)
    return binding, buffer, cap


def max_blades_for_gpu(limits) -> int:
    """The most blades a device with these ``limits`` (a wgpu ``device.limits`` or
    ``adapter.limits`` mapping) can hold: each per-blade buffer within one binding."""
    _binding, _buffer, cap = _gpu_caps(limits)
    return cap // max(GPU_STATE_BYTES_PER_BLADE, GPU_INDEX_BYTES_PER_BLADE)


def check_gpu_blade_count(count, limits, adapter="this adapter", name=None, error=BladeCountError) -> int:
    """Return ``count``, or raise ``error`` (a :class:`BladeCountError` subclass) when
    its largest GPU buffer would pass the device's ``max_storage_buffer_binding_size``
    (or ``max_buffer_size``). ``adapter`` names the device in the message."""
    count = int(count)
    binding, buffer, cap = _gpu_caps(limits)
    need = count * GPU_STATE_BYTES_PER_BLADE
    if count * max(GPU_STATE_BYTES_PER_BLADE, GPU_INDEX_BYTES_PER_BLADE) > cap:
        limit = max_blades_for_gpu(limits)
        total = count * (GPU_STATE_BYTES_PER_BLADE + GPU_INDEX_BYTES_PER_BLADE + GPU_COLLISION_BYTES_PER_BLADE)
        raise error(
            f"{_prefix(name)}count={count:,} blades need a {format_bytes(need)} storage buffer for their state "
            f"({GPU_STATE_BYTES_PER_BLADE} bytes per blade; {format_bytes(total)} of GPU memory in all), "
            f"but {adapter} allows {format_bytes(cap)} per buffer (max_storage_buffer_binding_size "
            f"{binding}, max_buffer_size {buffer}): {name or 'count'} must be at most {limit:,}",
            count, limit, need, cap, "GPU buffer",
        )
    return count
