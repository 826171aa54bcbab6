"""The sunlight's default of a GrassWidget follows the adapter that draws.

``core.params.sunlight_defaults``: ``shadows`` on where a GPU draws, off on a CPU adapter (lavapipe,
SwiftShader), where every pixel of grass and ground pays for it. A widget knows the kernel's adapter
at once; the browser engine's adapter only when the page reports it: the browser engine's start-up
status (``gpu_status`` "ok" with the adapter's vendor, architecture and description, whatever
the ``backend`` argument), classified by the same rule as the "auto" choice's probe
(:func:`grasswidget.core.engine_choice.page_adapter_kind`: a software adapter by name counts as a CPU).

A default is only a default: parameters the user passed (``params=``) are never changed, and once
the user (code or the panel's checkbox) has set ``shadows``, no later adapter report changes it.
"""

from __future__ import annotations

from ..core.engine_choice import page_adapter_kind
from ..core.params import sunlight_defaults

__all__ = ["ShadowsDefault", "engine_adapter_is_cpu"]


def engine_adapter_is_cpu(adapter_text: str) -> bool:
    """True when the browser engine's adapter (its ``gpu_status`` detail: vendor, architecture and
    description in words, e.g. "google swiftshader" or "nvidia ampere") is a software one by name;
    as in the "auto" rule, an adapter that names none of ``FALLBACK_MARKERS`` counts as a GPU."""
    report = {"webgpu": True, "adapter": True, "description": str(adapter_text or "")}
    return page_adapter_kind(report) != "hardware"


class ShadowsDefault:
    """Sets ``params``' sunlight to the default of the adapter that draws, while it is a default.

    Args:
        params: the widget's :class:`~grasswidget.core.params.GrassParams`.
        own: True when the widget made ``params`` itself (no ``params=`` argument); False: never
            touched.
    """

    def __init__(self, params, own: bool):
        self.params = params
        #: True while ``shadows`` is the widget's default (no user value yet).
        self.live = bool(own)
        self._applying = False
        params.observe(self._on_shadows, names="shadows")

    def _on_shadows(self, _change):
        if not self._applying:
            self.live = False  # the user's value from now on

    def apply(self, cpu_adapter: bool):
        """The default for a CPU adapter (``cpu_adapter`` True) or a GPU, unless the user has set it."""
        if not self.live:
            return
        self._applying = True
        try:
            for name, value in sunlight_defaults(cpu_adapter=cpu_adapter).items():
                setattr(self.params, name, value)
        finally:
            self._applying = False

    def apply_engine_adapter(self, adapter_text: str):
        """The browser engine reported its adapter (:func:`engine_adapter_is_cpu`)."""
        self.apply(engine_adapter_is_cpu(adapter_text))
