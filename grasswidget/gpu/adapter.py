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

__all__ = ["NoGPUAdapterError", "ensure_device", "adapter_info", "is_cpu_adapter", "INSTALL_HINT"]

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
    """Configure (once) and return the shared wgpu device that pygfx uses."""
    import wgpu
    from pygfx.renderers.wgpu import get_shared
    from pygfx.renderers.wgpu.engine.shared import Shared

    if Shared.get_instance() is None and not _state["configured"]:
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
        preferred = {"timestamp-query-inside-passes", "timestamp-query-inside-encoders"}
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
    return device


def adapter_info() -> dict:
    """Info of the adapter in use (name, type, backend)."""
    device = ensure_device()
    info = dict(device.adapter.info)
    info["summary"] = device.adapter.summary
    return info


def is_cpu_adapter() -> bool:
    """True when rendering runs on a CPU adapter (e.g. Mesa lavapipe)."""
    return adapter_info().get("adapter_type") == "CPU"


def announce_cpu_defaults():
    """Say once that a CPU adapter was found and cheap defaults are in use."""
    if _state["announced"]:
        return
    _state["announced"] = True
    msg = (
        f"grasswidget: rendering on a CPU adapter ({adapter_info()['summary']}); "
        "using pixel ratio 1 and no post-process anti-aliasing."
    )
    print(msg, file=sys.stderr)
    warnings.warn(msg, RuntimeWarning, stacklevel=3)
