"""AdapterProbe: a tiny anywidget that reports which WebGPU adapter the page's browser offers.

It shows nothing. When its first view renders it asks ``navigator.gpu.requestAdapter()``
(no device, no engine; at most 10 s) and sets ``report``::

    {"webgpu": bool,            # navigator.gpu exists
     "adapter": bool,           # requestAdapter() gave an adapter
     "fallback": bool | None,   # the adapter's isFallbackAdapter, None where the browser does not say
     "vendor": str, "architecture": str, "device": str, "description": str,   # adapter.info
     "detail": str}             # why there is no adapter, else ""

:func:`grasswidget.core.engine_choice.choose_engine` turns it into an engine. A browser
without WebGPU reports ``webgpu: False``; one that never shows the widget reports nothing.

For tests, a page may set ``globalThis.__grasswidgetTestAdapterInfo`` (e.g. ``{"vendor":
"nvidia", "architecture": "ampere", "fallback": false}``) before the probe renders: its
fields replace the real adapter's in the report (and ``"simulated": true`` is added).
"""

from __future__ import annotations

from pathlib import Path

import anywidget
from traitlets import Dict

__all__ = ["AdapterProbe"]


class AdapterProbe(anywidget.AnyWidget):
    """Reports the page's WebGPU adapter in ``report`` (empty until a view has rendered)."""

    # The module's text, not its path (see BrowserEngineWidget._esm).
    _esm = (Path(__file__).resolve().parent / "adapter_probe.js").read_text(encoding="utf-8")

    #: What the browser said (see the module docstring); {} until the first view has rendered.
    report = Dict({}).tag(sync=True)

    def on_report(self, callback):
        """Call ``callback(report)`` once, when the browser's report arrives (at once if it has)."""
        if self.report:
            callback(dict(self.report))
            return

        def once(change):
            if change["new"]:
                self.unobserve(once, names="report")
                callback(dict(change["new"]))

        self.observe(once, names="report")
