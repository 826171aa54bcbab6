"""What the widget layer needs to know about the two engines before or beside a view.

The notebook front end imports the views package only (never ``grasswidget.gpu`` or
``grasswidget.browser``; tests/test_architecture.py holds it to that). This module is the
part of the views package that answers questions about an engine that has no view yet:
the kernel's adapter, how many blades each engine takes, the "auto" rule's probe of the
page's adapter, a live page's limits, and a kernel scene that films what a browser view
shows. Imports of the GPU layer are lazy: asking about the browser engine never opens
the kernel's adapter (2 s on lavapipe).
"""

from __future__ import annotations

from contextlib import contextmanager

from ..core.memory import max_blades_for_memory

__all__ = ["BROWSER_MAX_BLADES", "kernel_adapter", "kernel_is_cpu", "kernel_max_blades", "check_kernel_blades",
           "browser_max_blades", "adapter_probe", "check_live_page", "kernel_film_scene"]

#: The most blades the browser engine takes (its device may allow fewer; it says so then).
BROWSER_MAX_BLADES = 1 << 22


def kernel_adapter() -> tuple:
    """(kind, name) of the kernel's adapter: kind "gpu", "cpu" or "none" (no usable adapter,
    :class:`~grasswidget.errors.NoGPUAdapterError`), name e.g. "llvmpipe" or "NVIDIA H100"."""
    from ..errors import NoGPUAdapterError
    from ..gpu.adapter import adapter_info

    try:
        info = adapter_info()
    except NoGPUAdapterError:
        return "none", ""
    name = str(info.get("device") or info.get("summary") or "").split(" (")[0]
    return ("cpu" if info.get("adapter_type") == "CPU" else "gpu"), name


def kernel_is_cpu() -> bool:
    """True when the kernel renders on a CPU adapter (lavapipe, llvmpipe, SwiftShader).
    Raises NoGPUAdapterError where the kernel has no adapter at all."""
    from ..gpu.adapter import is_cpu_adapter

    return is_cpu_adapter()


def kernel_max_blades() -> int:
    """The most blades the kernel engine's field takes here (memory and the GPU's buffer limits)."""
    from ..gpu.field import max_blade_count

    return max_blade_count()


def check_kernel_blades(count: int, name: str = "blades") -> int:
    """``count`` if a kernel field of that many blades fits in memory and the GPU's buffers; else
    a GrassValueError naming ``name`` and the limit (as GrassScene and the command line check)."""
    from ..gpu.field import check_blade_count_fits

    return check_blade_count_fits(count, name)


def browser_max_blades() -> int:
    """The most blades the browser engine takes: :data:`BROWSER_MAX_BLADES`, or fewer where the
    kernel's memory (which still builds the blade state) holds fewer."""
    host = max_blades_for_memory()
    return BROWSER_MAX_BLADES if host is None else min(BROWSER_MAX_BLADES, host)


def adapter_probe():
    """A new :class:`~grasswidget.browser.adapter_probe.AdapterProbe`: the small anywidget that asks
    the page for its WebGPU adapter (shown with the view of an "auto" widget)."""
    from ..browser.adapter_probe import AdapterProbe

    return AdapterProbe()


def check_live_page(path, blade_count: int):
    """Check what ``save_html`` would write: ``path`` ends in .html in an existing folder, at most
    ``browser.page.PAGE_MAX_BLADES`` blades. Raises GrassValueError / MissingFileError naming them."""
    from ..browser.page import check_page_blades, check_page_path

    check_page_path(path)
    check_page_blades(blade_count)


@contextmanager
def kernel_film_scene(view, size, params, camera: dict):
    """A kernel :class:`~grasswidget.gpu.scene.GrassScene` holding what ``view`` shows now (its blade
    state, colliders and ``camera``), with a copy of ``params``; released on leaving the block.
    ``save_animation`` films a browser view with it (needs an adapter in the kernel)."""
    from ..gpu.scene import GrassScene

    state = view.read_state()
    scene = GrassScene(view.blades, size=size, params=params.copy())
    try:
        scene.field.write_state(state)
        live = view.colliders
        scene.colliders = list(live)
        scene.colliders.set_array(getattr(live, "bulk", ()))
        scene.look(camera["position"], camera["target"], camera["fov_deg"])
        yield scene
    finally:
        scene.release()
