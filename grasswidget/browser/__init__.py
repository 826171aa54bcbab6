"""The browser engine: the project's WGSL simulation, culling and ribbons in the
notebook's browser through WebGPU (an anywidget; see :mod:`grasswidget.browser.engine_widget`).

:mod:`grasswidget.browser.browser_wgsl` renders the shader files for the browser's
bindings and :mod:`grasswidget.browser.uniforms` packs the uniforms; neither
imports GPU code.

The widget (:class:`BrowserEngineWidget`, which needs anywidget) loads on first use, so the pure
parts (``wgsl``, ``uniforms``, ``page``'s limits) import without the notebook packages.
"""

__all__ = ["BrowserEngineWidget", "BrowserTimeoutError"]


def __getattr__(name):
    if name == "BrowserEngineWidget":
        from .engine_widget import BrowserEngineWidget

        return BrowserEngineWidget
    if name == "BrowserTimeoutError":
        from ..errors import BrowserTimeoutError

        return BrowserTimeoutError
    from ..errors import UnknownNameError

    raise UnknownNameError(f"module {__name__!r} has no attribute {name!r}")
