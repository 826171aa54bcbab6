"""Which engine a ``backend="auto"`` GrassWidget runs: the rule, pure.

The design is the kernel engine (pygfx in the kernel, frames streamed to the page).
Where the kernel renders on a CPU adapter (Mesa lavapipe / llvmpipe, any adapter of
type CPU) and the page's browser offers a hardware WebGPU adapter (not SwiftShader,
llvmpipe, WARP or another fallback), the browser engine draws instead: the meadow then
runs on the student's GPU. Everything else stays with the kernel engine.

Inputs:

* the kernel's adapter: ``kind`` "gpu", "cpu" or "none" (no usable adapter) and its
  name (for the sentence);
* the page's adapter report, as the adapter probe sends it
  (:mod:`grasswidget.browser.adapter_probe`), or None when no view has reported:
  ``{"webgpu": bool, "adapter": bool, "fallback": bool | None, "vendor": str,
  "architecture": str, "device": str, "description": str, "detail": str}``.

Output: an :class:`EngineChoice` (``engine`` "kernel" or "browser", ``reason``: one
sentence saying which engine runs and why).

+-------------+---------------------------+-----------+
| kernel      | page                      | engine    |
+=============+===========================+===========+
| gpu         | anything (or no report)   | kernel    |
| cpu         | hardware WebGPU adapter   | browser   |
| cpu         | fallback adapter          | kernel    |
| cpu         | no WebGPU / no adapter    | kernel    |
| cpu         | no report (no view yet)   | kernel    |
| none        | any WebGPU adapter        | browser   |
| none        | no report (no view yet)   | browser   |
| none        | no WebGPU / no adapter    | kernel    |
+-------------+---------------------------+-----------+

With no adapter in the kernel the browser is the only engine that can draw, so it is
tried first; if the page has no WebGPU either, nothing can draw and the sentence says so.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import GrassValueError

__all__ = ["EngineChoice", "KERNEL_KINDS", "FALLBACK_MARKERS", "page_adapter_kind", "page_adapter_name",
           "choose_engine"]

#: What the kernel's adapter can be: a GPU, a CPU adapter (lavapipe), or none usable.
KERNEL_KINDS = ("gpu", "cpu", "none")

#: Words in a WebGPU adapter's vendor / architecture / device / description that mark a
#: software (CPU) implementation, whatever ``isFallbackAdapter`` says: Chromium's
#: SwiftShader reports vendor "google", architecture "swiftshader"; Mesa's llvmpipe and
#: lavapipe, Microsoft's WARP ("Microsoft Basic Render Driver") and softpipe are CPU ones too.
FALLBACK_MARKERS = ("swiftshader", "llvmpipe", "lavapipe", "softpipe", "basic render", "warp", "cpu")

_INFO_FIELDS = ("vendor", "architecture", "device", "description")


@dataclass(frozen=True)
class EngineChoice:
    """The engine a "auto" widget runs and why.

    Attributes:
        engine: "kernel" or "browser".
        reason: one sentence naming the engine and the adapters that decided it.
        page: what the page offered: "hardware", "fallback", "none", or None (no report).
    """

    engine: str
    reason: str
    page: str | None = None


def _info_text(report: dict) -> list:
    return [str(report.get(k) or "").strip() for k in _INFO_FIELDS]


def page_adapter_kind(report) -> str | None:
    """What a page's adapter report says: "hardware" (a WebGPU adapter that is not a fallback),
    "fallback" (``isFallbackAdapter`` true, or SwiftShader / llvmpipe / WARP ... by name),
    "none" (no ``navigator.gpu``, no adapter, or a report that cannot be read), or None when
    there is no report (None given)."""
    if report is None:
        return None
    if not isinstance(report, dict) or not report.get("webgpu") or not report.get("adapter"):
        return "none"
    if report.get("fallback") is True:
        return "fallback"
    text = " ".join(_info_text(report)).lower()
    if any(marker in text.split() or (len(marker) > 4 and marker in text) for marker in FALLBACK_MARKERS):
        return "fallback"
    return "hardware"


def page_adapter_name(report) -> str:
    """The page's adapter in words ("nvidia ampere", "google swiftshader"), or "" when unknown."""
    if not isinstance(report, dict):
        return ""
    seen = []
    for part in _info_text(report):
        if part and part.lower() not in (s.lower() for s in seen):
            seen.append(part)
    return " ".join(seen)


def choose_engine(kernel_kind: str, kernel_name: str = "", page_report=None) -> EngineChoice:
    """The engine of a ``backend="auto"`` widget (see the module docstring's table).

    Args:
        kernel_kind: the kernel's adapter, one of :data:`KERNEL_KINDS`.
        kernel_name: its name in words (e.g. "llvmpipe"), for the sentence; "" if unknown.
        page_report: the page's adapter report (a dict from the probe), or None before any.

    Raises GrassValueError naming ``kernel_kind`` and the allowed values for another kind.
    """
    if kernel_kind not in KERNEL_KINDS:
        raise GrassValueError(f"kernel_kind must be one of {', '.join(map(repr, KERNEL_KINDS))}; got {kernel_kind!r}")
    page = page_adapter_kind(page_report)
    page_name = page_adapter_name(page_report)
    named = f" ({kernel_name})" if kernel_name else ""
    page_named = f" ({page_name})" if page_name else ""
    detail = str(page_report.get("detail") or "").strip() if isinstance(page_report, dict) else ""
    no_webgpu = "WebGPU is not available in this browser" + (f" ({detail})" if detail else "")

    if kernel_kind == "gpu":
        return EngineChoice("kernel", f"kernel engine: the kernel renders on a GPU{named}", page)
    if kernel_kind == "cpu":
        where = f"the kernel renders on a CPU adapter{named}"
        if page == "hardware":
            return EngineChoice("browser", f"browser engine: {where} and this browser offers a GPU{page_named}",
                                page)
        if page == "fallback":
            return EngineChoice("kernel", f"kernel engine: {where} and this browser's WebGPU adapter is a CPU "
                                          f"fallback too{page_named}", page)
        if page == "none":
            return EngineChoice("kernel", f"kernel engine: {where} and {no_webgpu}", page)
        return EngineChoice("kernel", f"kernel engine: {where}; no view has reported its browser's WebGPU "
                                      "adapter yet (the engine is chosen when the widget is first shown)", page)
    # No adapter in the kernel: the browser is the only engine that can draw.
    if page in ("hardware", "fallback"):
        return EngineChoice("browser", f"browser engine: the kernel has no WebGPU adapter and this browser offers "
                                       f"one{page_named}", page)
    if page == "none":
        return EngineChoice("kernel", f"kernel engine: the kernel has no WebGPU adapter and {no_webgpu}: "
                                      "nothing can draw here", page)
    return EngineChoice("browser", "browser engine: the kernel has no WebGPU adapter (the browser's is asked "
                                   "when the widget is shown)", page)
