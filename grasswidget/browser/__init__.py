"""The browser engine: the project's WGSL simulation, culling and ribbons in the
notebook's browser through WebGPU (an anywidget; see :mod:`grasswidget.browser.view`).

:mod:`grasswidget.browser.wgsl` renders the shader files for the browser's
bindings and :mod:`grasswidget.browser.uniforms` packs the uniforms; neither
imports GPU code.
"""

from .view import BrowserTimeoutError, BrowserView

__all__ = ["BrowserView", "BrowserTimeoutError"]
