"""The errors grasswidget raises on purpose (pure Python; no GPU import).

Every one derives from :class:`GrassError`, so ``except gw.GrassError`` catches
anything the project raises deliberately, and each is also the built-in error
it has always been (``ValueError`` for bad input, ``RuntimeError`` for the
environment), so existing ``except ValueError`` code keeps working.
"""

from __future__ import annotations

__all__ = ["GrassError", "BladeCountError", "BladeLimitError", "WindShaderError", "NoGPUAdapterError"]


class GrassError(Exception):
    """Root of every error grasswidget raises on purpose."""


class BladeCountError(GrassError, ValueError):
    """A blade count that does not fit in memory (host RAM or a GPU buffer); raised
    before anything is allocated (see :mod:`grasswidget.memory`).

    Attributes: ``count`` (what was asked), ``limit`` (the most blades that fit),
    ``need_bytes`` (what ``count`` blades would take), ``available_bytes`` (what
    there is) and ``where`` ("host memory" or "GPU buffer").
    """

    def __init__(self, message, count=None, limit=None, need_bytes=None, available_bytes=None, where=None):
        super().__init__(message)
        self.count, self.limit, self.where = count, limit, where
        self.need_bytes, self.available_bytes = need_bytes, available_bytes


class BladeLimitError(BladeCountError):
    """The blade count does not fit the device's storage-buffer limits."""


class WindShaderError(GrassError, ValueError):
    """A ``wind_wgsl`` snippet (the body of ``user_wind``) does not compile.

    Attributes: ``line`` and ``column`` (1-based, within the snippet; None when
    the error is not inside it), ``reason`` (naga's one-line summary) and
    ``naga_message`` (the full message; its line numbers are those of the whole
    simulation shader). The previous wind stays in force.
    """

    def __init__(self, message, line=None, column=None, reason="", naga_message=""):
        super().__init__(message)
        self.line, self.column, self.reason, self.naga_message = line, column, reason, naga_message


class NoGPUAdapterError(GrassError, RuntimeError):
    """No WebGPU adapter that pygfx can use; the message says what to install."""
