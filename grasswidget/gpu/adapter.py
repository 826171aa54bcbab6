"""Pick the GPU adapter and configure the device pygfx will create.

Call :func:`ensure_device` before the first pygfx renderer exists (GrassField and
GrassScene do). It picks the best usable adapter (discrete > integrated > virtual >
CPU; Vulkan/Metal/D3D12 only, since pygfx needs ``float32-filterable``), raises
:class:`NoGPUAdapterError` with what to install when there is none, asks for the
adapter's largest storage-buffer limits (so large fields fit) and for timestamp
queries where available.
"""

from __future__ import annotations

import os
import sys
import warnings

from ..errors import NoGPUAdapterError

__all__ = ["NoGPUAdapterError", "ensure_device", "missing_capabilities", "adapter_info", "is_cpu_adapter",
           "cpu_notice", "announce_cpu_defaults", "INSTALL_HINT"]

INSTALL_HINT = (
    "grasswidget needs a WebGPU adapter (Vulkan, Metal or D3D12). None was found. "
    "On Debian/Ubuntu without a GPU, install Mesa's CPU Vulkan driver: "
    "`sudo apt-get install -y mesa-vulkan-drivers libvulkan1`; with a GPU, install its Vulkan driver."
)

_RANK = {"DiscreteGPU": 0, "IntegratedGPU": 1, "VirtualGPU": 2, "CPU": 3}

_state = {"adapter": None, "configured": False, "announced": False}


def _usable(adapter):
    info = adapter.info
    if str(info.get("backend_type", "")).lower() in ("opengl", "gl", "null"):
        return False
    return "float32-filterable" in adapter.features


def select_adapter():
    """The best usable adapter, or raise NoGPUAdapterError."""
    import wgpu

    try:
        adapters = wgpu.gpu.enumerate_adapters_sync()
    except Exception as err:  # no loader, no driver
        raise NoGPUAdapterError(f"{INSTALL_HINT} (wgpu said: {err})") from None
    usable = [a for a in adapters if _usable(a)]
    if not usable:
        found = "; ".join(a.summary for a in adapters) or "none"
        raise NoGPUAdapterError(f"{INSTALL_HINT} Adapters seen: {found}.")
    want = os.environ.get("GRASSWIDGET_ADAPTER")
    if want:
        named = [a for a in usable if want.lower() in a.summary.lower()]
        if named:
            return named[0]
    return sorted(usable, key=lambda a: _RANK.get(a.info.get("adapter_type"), 9))[0]


def ensure_device():
    """Configure (once) and return the shared wgpu device that pygfx uses (pygfx keeps one
    device for the process: once found, it is returned at once; frames ask for it several times)."""
    device = _state.get("device")
    if device is not None:
        return device
    import wgpu
    from pygfx.renderers.wgpu import get_shared

    from .. import compat
    from .raster_walks import ONE_WALK_FEATURES

    if not compat.default_device_exists() and not _state["configured"]:
        adapter = select_adapter()
        limits = adapter.limits
        required_limits = {
            key: limits[key]
            for key in ("max-storage-buffer-binding-size", "max-buffer-size")
            if key in limits
        }
        features = {"float32-filterable"}
        if "timestamp-query" in adapter.features:
            features.add("timestamp-query")
        # 64-bit atomics: the compute rasterizer's one walk (gpu/raster_walks.py) where offered.
        preferred = {"timestamp-query-inside-passes", "timestamp-query-inside-encoders", *ONE_WALK_FEATURES}
        wgpu.preconfigure_default_device(
            "grasswidget",
            adapter=adapter,
            required_features=features,
            preferred_features=preferred & set(adapter.features),
            required_limits=required_limits,
        )
        _state["configured"] = True
    try:
        device = get_shared().device
    except Exception as err:
        if "adapter" in str(err).lower() or "float32-filterable" in str(err):
            raise NoGPUAdapterError(f"{INSTALL_HINT} (wgpu said: {err})") from None
        raise
    _state["adapter"] = device.adapter
    if not _state["configured"] and not _state.get("checked_existing"):
        _state["checked_existing"] = True
        missing = missing_capabilities(device)
        if missing:
            msg = (
                "grasswidget: pygfx's GPU device was created before grasswidget could configure it, "
                f"so it lacks {'; '.join(missing)}. Create the GrassField/GrassScene/GrassWidget "
                "(or call grasswidget.gpu.adapter.ensure_device()) before any other pygfx renderer."
            )
            print(msg, file=sys.stderr)
            warnings.warn(msg, RuntimeWarning, stacklevel=2)
    _state["device"] = device
    return device


def missing_capabilities(device) -> list[str]:
    """What ``device`` lacks of what grasswidget would have asked its adapter for:
    the adapter's largest storage-buffer limits and timestamp queries (one line each)."""
    missing = []
    adapter = device.adapter
    for key, why in (("max-storage-buffer-binding-size", "fewer blades fit"), ("max-buffer-size", "fewer blades fit")):
        have, could = device.limits.get(key), adapter.limits.get(key)
        if have is not None and could is not None and int(have) < int(could):
            missing.append(f"the adapter's {key} ({int(could)} bytes; the device has {int(have)}: {why})")
    if "timestamp-query" in adapter.features and "timestamp-query" not in device.features:
        missing.append("timestamp-query (no GPU timings in stats and benchmarks)")
    return missing


def adapter_info() -> dict:
    """Info of the adapter in use (name, type, backend)."""
    device = ensure_device()
    info = dict(device.adapter.info)
    info["summary"] = device.adapter.summary
    return info


def is_cpu_adapter() -> bool:
    """True when rendering runs on a CPU adapter (e.g. Mesa lavapipe)."""
    return adapter_info().get("adapter_type") == "CPU"


def cpu_notice(short: bool = False) -> str | None:
    """The one-line notice for a CPU adapter, or None when rendering runs on a GPU.

    It says what is true on a CPU adapter: the live view is drawn without
    post-process anti-aliasing (to keep frames cheap), while exports (``save_png``,
    Save PNG, ``save_animation``, the CLI snapshot) are anti-aliased by rendering
    at 2x and filtering down. E.g. ``"grasswidget: CPU adapter (llvmpipe): live
    view without anti-aliasing, exports anti-aliased"``; ``short=True`` gives the
    form the widget's "details" line shows, without the ``grasswidget:`` prefix.
    """
    if not is_cpu_adapter():
        return None
    info = adapter_info()
    name = str(info.get("device") or info["summary"]).split(" (")[0]
    text = f"CPU adapter ({name}): live view without anti-aliasing, exports anti-aliased"
    return text if short else f"grasswidget: {text}"


def announce_cpu_defaults():
    """Say once per process, as one line of information on stdout (not stderr, not
    a warning: in a notebook it is plain output, not a red box), that a CPU
    adapter was found and cheap defaults are in use. :func:`cpu_notice` gives the
    text at any time (the widget's stats line shows it)."""
    if _state["announced"]:
        return
    _state["announced"] = True
    msg = cpu_notice()
    if msg:
        print(msg, file=sys.stdout, flush=True)
