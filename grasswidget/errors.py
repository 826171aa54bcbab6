"""The errors grasswidget raises on purpose (pure Python; no GPU import).

Every one derives from :class:`GrassError`, so ``except gw.GrassError`` catches
anything the project raises deliberately, and each is also the built-in error
it has always been (``ValueError`` for a bad value, ``TypeError`` for a value of
the wrong kind, ``RuntimeError`` for the environment, ...), so existing
``except ValueError`` code keeps working.

==============================  ==================================  ===============================================
error                           also a                              raised for
==============================  ==================================  ===============================================
``GrassValueError``             ``ValueError``                      a bad value (range, shape, choice, file suffix)
``GrassTypeError``              ``TypeError``                       an argument of the wrong kind
``ParameterError``              ``GrassValueError``, ``TraitError``  a trait value outside its range or choices
``UnknownNameError``            ``AttributeError``                  an unknown trait/attribute name (with a hint)
``ReadOnlyAttributeError``      ``AttributeError``                  assigning an attribute that can only be read
``MissingLimitError``           ``KeyError``                        device limits without the buffer-size keys
``BladeCountError``             ``GrassValueError``                 more blades than memory holds
``BladeLimitError``             ``BladeCountError``                 more blades than one GPU buffer binding holds
``WindShaderError``             ``GrassValueError``                 a ``wind_wgsl`` snippet that does not compile
``ExerciseShaderError``         ``GrassValueError``                 exercise WGSL that does not compile or breaks a rule
``IsolatedRunError``             ``RuntimeError``                    user code that crashed, hung or overran the isolated worker
``MissingFileError``            ``FileNotFoundError``               an output folder or shipped shader not there
``MissingDependencyError``      ``ImportError``                     an optional package a feature needs
``NoGPUAdapterError``           ``RuntimeError``                    no usable WebGPU adapter
``WidgetClosedError``           ``RuntimeError``                    using a closed widget or a released scene/field
``UpstreamChangedError``        ``RuntimeError``                    a pygfx internal that compat.py relies on moved
``BrowserTimeoutError``         ``TimeoutError``                    the browser view did not answer in time
``PageBuildError``              ``RuntimeError``                    a live page that could not be described (a bug)
``TraceFileError``              ``GrassValueError``                 a traces file that cannot be read back
==============================  ==================================  ===============================================
"""

from __future__ import annotations

from traitlets import TraitError

__all__ = [
    "GrassError", "GrassValueError", "GrassTypeError", "ParameterError", "UnknownNameError", "ReadOnlyAttributeError",
    "MissingLimitError",
    "BladeCountError", "BladeLimitError", "WindShaderError", "ExerciseShaderError", "IsolatedRunError",
    "MissingFileError", "MissingDependencyError",
    "NoGPUAdapterError", "WidgetClosedError", "UpstreamChangedError", "BrowserTimeoutError",
    "PageBuildError", "TraceFileError",
]


class GrassError(Exception):
    """Root of every error grasswidget raises on purpose."""


class GrassValueError(GrassError, ValueError):
    """A bad value: out of range, wrong shape, not one of the choices. The message
    names the argument, the allowed range and what was given."""


class GrassTypeError(GrassError, TypeError):
    """An argument of the wrong kind (e.g. a string where a Blades is expected)."""


class ParameterError(GrassValueError, TraitError):
    """A parameter value outside its documented range or choices.

    A traitlets ``TraitError`` (what traitlets and ipywidgets expect) that is also
    a ``ValueError`` and a :class:`GrassError`, so ``except ValueError`` catches
    bad input too.
    """


class UnknownNameError(GrassError, AttributeError):
    """An unknown attribute name, e.g. a misspelt trait (``params.wind_strenght``);
    the message suggests the closest name."""


class ReadOnlyAttributeError(GrassError, AttributeError):
    """Assigning an attribute that can only be read (e.g. ``w.stats = ...`` on a GrassWidget)."""


class MissingLimitError(GrassError, KeyError):
    """Device limits given without ``max-storage-buffer-binding-size`` or
    ``max-buffer-size`` (see :mod:`grasswidget.core.memory`)."""


class BladeCountError(GrassValueError):
    """A blade count that does not fit in memory (host RAM or a GPU buffer); raised
    before anything is allocated (see :mod:`grasswidget.core.memory`).

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


class WindShaderError(GrassValueError):
    """A ``wind_wgsl`` snippet (the body of ``user_wind``) does not compile.

    Attributes: ``line`` and ``column`` (1-based, within the snippet; None when
    the error is not inside it), ``reason`` (naga's one-line summary) and
    ``naga_message`` (the full message; its line numbers are those of the whole
    simulation shader). The previous wind stays in force.
    """

    def __init__(self, message, line=None, column=None, reason="", naga_message=""):
        super().__init__(message)
        self.line, self.column, self.reason, self.naga_message = line, column, reason, naga_message


class ExerciseShaderError(GrassValueError):
    """Exercise WGSL (the functions a student writes, see ``gw.exercise``) that does
    not compile, misses a function, changes a signature or uses a loop.

    The sibling of :class:`WindShaderError`, with the same attributes: ``line`` and
    ``column`` (1-based, within the student's code; None when the error is not inside
    it), ``reason`` (one line) and ``naga_message`` (the compiler's full message, ""
    for the checks made before compiling; its line numbers are those of the whole shader).
    """

    def __init__(self, message, line=None, column=None, reason="", naga_message=""):
        super().__init__(message)
        self.line, self.column, self.reason, self.naga_message = line, column, reason, naga_message

    def _render_traceback_(self):
        # IPython shows what this returns instead of the traceback: the message names the
        # student's line, the frames inside grasswidget would only bury it (a few KB).
        return [f"{type(self).__name__}: {self}"]


class IsolatedRunError(GrassError, RuntimeError):
    """Work on user code in the isolated worker process (:mod:`grasswidget.gpu.isolation`)
    that did not come back: the worker crashed (e.g. a compiler's segmentation fault), ran
    past its time limit, past its memory limit, or lost its GPU device. The kernel's own
    process and device were never touched; the next call starts a fresh worker.

    Attributes: ``cause`` ("crash", "time", "memory" or "device lost"; "start" when the
    worker itself could not start, which is no fault of the code), ``verdict`` (one
    line naming the cause and the limit, e.g. "exceeded the 60 s time limit"), ``limit``
    (the seconds or megabytes of the limit, None for a crash or a lost device) and
    ``detail`` (the signal, or the last lines the worker printed). Grading and the kernel's
    compiles turn it into an :class:`ExerciseShaderError` or :class:`WindShaderError`.
    """

    def __init__(self, message, cause="crash", verdict="", limit=None, detail=""):
        super().__init__(message)
        self.cause, self.verdict, self.limit, self.detail = cause, verdict or message, limit, detail


class MissingFileError(GrassError, FileNotFoundError):
    """A file or folder grasswidget needs is not there (an export's folder, a
    shader file of an incomplete installation)."""


class MissingDependencyError(GrassError, ImportError):
    """An optional package a feature needs is not installed; the message says
    what to ``pip install``."""


class NoGPUAdapterError(GrassError, RuntimeError):
    """No WebGPU adapter that pygfx can use; the message says what to install."""


class WidgetClosedError(GrassError, RuntimeError):
    """A closed GrassWidget, or a released GrassScene / GrassField, was asked to do
    something; create a new one."""


class UpstreamChangedError(GrassError, RuntimeError):
    """A pygfx/wgpu internal that :mod:`grasswidget.compat` relies on is not where
    it was in the version checked; the message names it."""


class BrowserTimeoutError(GrassError, TimeoutError):
    """The browser view did not answer a request in time."""


class PageBuildError(GrassError, RuntimeError):
    """The live page's controls could not be described as patches of the browser
    engine's state (two controls touch the same state, or the ball's position does
    not map affinely onto it): a bug in grasswidget, not bad input."""


class TraceFileError(GrassValueError):
    """A traces file (.csv / .npz) that :func:`grasswidget.load_traces` cannot read back:
    empty, truncated, not text, or not written by ``save_traces``. The message names the
    file and what is wrong with it."""


def refuse_when_closed(what: str, exempt=("release", "close")):
    """Class decorator: every public method the class itself defines raises
    :class:`WidgetClosedError` ("this {what} is released ...") once the instance's
    ``closed`` attribute is true, before its body runs. Methods named in ``exempt``
    (the releasing call, which may be repeated) and class/static methods are left as
    they are; so are properties (reading a released object's data is harmless)."""
    import functools

    def guard(method):
        @functools.wraps(method)
        def checked(self, *args, **kwargs):
            if getattr(self, "closed", False):  # (not yet built, or called unbound: the method decides)
                raise WidgetClosedError(f"this {what} is released (its GPU memory was freed); "
                                        f"{method.__name__}() cannot run: create a new {what}")
            return method(self, *args, **kwargs)

        return checked

    def decorate(cls):
        for name, value in list(vars(cls).items()):
            if (name.startswith("_") or name in exempt or isinstance(value, (classmethod, staticmethod, type))
                    or not callable(value)):
                continue
            setattr(cls, name, guard(value))
        return cls

    return decorate
