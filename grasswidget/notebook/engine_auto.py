"""``backend="auto"``: the engine chosen by the kernel's adapter and the page's.

:class:`AutoEngine` holds what a GrassWidget needs for it: the kernel's adapter kind,
the :class:`~grasswidget.core.engine_choice.EngineChoice` in force (its ``reason`` is the
one line the widget shows) and, where the page can still change it, the adapter probe
(:class:`~grasswidget.browser.adapter_probe.AdapterProbe`) to put beside the view.

* Kernel on a GPU: the kernel engine, decided at once (no probe).
* Kernel with no usable adapter: the browser engine, decided at once (no probe; a
  browser without WebGPU then falls back to the kernel as any browser widget does).
* Kernel on a CPU adapter: the kernel engine starts at once (its frames do not wait for
  anything); the probe reports the page's adapter when the widget is first shown, and
  ``on_choice(choice)`` runs once with the rule's answer (the widget switches to the
  browser engine when it says "browser"). With no view ever shown (a script calling
  ``save_png()``, a headless run) nothing is reported and the kernel engine stays.
"""

from __future__ import annotations

from ..core.engine_choice import EngineChoice, choose_engine
from ..views.engines import adapter_probe, kernel_adapter

__all__ = ["AutoEngine", "kernel_adapter"]


class AutoEngine:
    """The "auto" rule for one widget (see the module docstring).

    Args:
        kernel_kind, kernel_name: the kernel's adapter (:func:`kernel_adapter`).
        on_choice: ``on_choice(choice)`` runs once when the page's report decides
            (only where the kernel is on a CPU adapter).

    Attributes:
        choice: the :class:`EngineChoice` in force (before the page reports: the kernel's).
        decided: True once nothing can change the choice any more.
        probe: the AdapterProbe widget to show with the view, or None when none is needed.
    """

    def __init__(self, kernel_kind: str, kernel_name: str, on_choice):
        self.kernel_kind = kernel_kind
        self.kernel_name = kernel_name
        self._on_choice = on_choice
        self.choice: EngineChoice = choose_engine(kernel_kind, kernel_name, None)
        self.decided = kernel_kind != "cpu"
        self.probe = None
        if not self.decided:
            self.probe = adapter_probe()
            self.probe.on_report(self._on_report)

    @property
    def engine(self) -> str:
        """The engine to start with: "kernel" or "browser"."""
        return self.choice.engine

    def _on_report(self, report):
        if self.decided:
            return
        self.decided = True
        self.choice = choose_engine(self.kernel_kind, self.kernel_name, report)
        self._on_choice(self.choice)

    def close(self):
        self.decided = True
        if self.probe is not None:
            from .layout import close_widgets

            close_widgets(self.probe)  # with its Layout
