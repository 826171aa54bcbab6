"""Compile and run user WGSL in a worker process, away from the kernel's process and device.

Some shaders take a compiler or a driver down instead of failing with an error: a
segmentation fault in ``create_shader_module``, a pipeline whose compile allocates
without end, a GPU device lost for every later call. :mod:`grasswidget.core.wgsl_limits`
refuses the known shapes of such code by its text; what is left runs here.

An :class:`IsolatedWorker` is one long-lived child Python process with its own wgpu
device (the same adapter the kernel would pick). :meth:`IsolatedWorker.call` sends it a
picklable function and arguments and waits for the result under a time limit, while
watching the child's resident memory against a memory limit; on a CPU adapter (lavapipe,
where the device's memory is the child's) the child also runs under an address-space limit
(``RLIMIT_AS``) as a backstop. When the child crashes, runs past
a limit (it is killed) or reports its device lost (it exits), the call raises
:class:`~grasswidget.errors.IsolatedRunError` naming the cause, and the next call starts
a fresh child (about 1-2 s on lavapipe). The kernel's process and device are never
touched, so every widget and scene in it keeps working.

Used for:

- :func:`check_compute` -- compile a compute shader (module and pipeline) in the worker
  before the kernel compiles it: the simulation shader with a ``wind_wgsl`` body or
  function overrides (:class:`~grasswidget.gpu.simulation.Simulation`); only what passed
  is compiled in the kernel. Passed shaders are remembered (by their text), so a second
  field with the same code pays nothing;
- grading (:func:`grasswidget.tools.grading.grade`): the whole grade runs in the worker.

Inside the worker, :func:`in_worker` is True and :func:`check_compute` compiles directly
(the worker is the isolation). Limits: :data:`DEFAULT_TIMEOUT_S` seconds per call (60),
:data:`DEFAULT_MEMORY_MB` MB of resident memory above the child's start (1536);
:func:`shared_worker` is the process-wide worker, :func:`set_limits` changes its limits.
"""

from __future__ import annotations

import atexit
import hashlib
import importlib
import os
import pickle
import select
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

from ..errors import GrassTypeError, GrassValueError, IsolatedRunError, NoGPUAdapterError

__all__ = ["IsolatedWorker", "shared_worker", "set_limits", "check_compute", "in_worker", "verdict_message",
           "probe_entry", "PROBE_ENTRY",
           "DEFAULT_TIMEOUT_S",
           "DEFAULT_MEMORY_MB", "START_TIMEOUT_S"]

#: Seconds one call may take (a grade on lavapipe takes 0.3-3 s; a loaded machine is slower).
DEFAULT_TIMEOUT_S = 60.0
#: Megabytes of resident memory the worker may grow by above what it used when ready.
DEFAULT_MEMORY_MB = 1536
#: Seconds a new worker may take to import grasswidget and open its device.
START_TIMEOUT_S = 120.0
#: The environment variable that marks the worker process.
WORKER_ENV = "GRASSWIDGET_ISOLATED_WORKER"
_POLL_S = 0.02
_LOST = ("device is lost", "device lost", "devicelost", "device has been lost")
_HEADER = struct.Struct("<Q")


def in_worker() -> bool:
    """True inside an isolated worker process (where user code may compile directly)."""
    return os.environ.get(WORKER_ENV) == "1"


def _status_kb(pid, key):
    try:
        with open(f"/proc/{pid}/status") as f:
            for row in f:
                if row.startswith(key + ":"):
                    return int(row.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def _own_kb(key):
    return _status_kb("self", key) or 0


def _device_lost(text: str) -> bool:
    low = text.lower()
    return any(k in low for k in _LOST)


# ------------------------------------------------------------------ the child


def _send(stream, obj):
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(data)) + data)
    stream.flush()


def _recv(stream):
    head = stream.read(_HEADER.size)
    if len(head) < _HEADER.size:
        return None
    (n,) = _HEADER.unpack(head)
    return pickle.loads(stream.read(n))


def _pack_exception(err):
    attrs = {}
    for key, value in vars(err).items():
        try:
            pickle.dumps(value)
        except Exception:  # noqa: BLE001 - an attribute we cannot carry stays behind
            continue
        attrs[key] = value
    return type(err).__module__, type(err).__qualname__, str(err), attrs, traceback.format_exc()


def _unpack_exception(packed):
    module, qualname, message, attrs, tb = packed
    cls = None
    try:
        cls = importlib.import_module(module)
        for part in qualname.split("."):
            cls = getattr(cls, part)
    except Exception:  # noqa: BLE001 - a class the kernel cannot import
        cls = None
    if not (isinstance(cls, type) and issubclass(cls, Exception)):
        return IsolatedRunError(f"the isolated worker raised {qualname}: {message}", "crash", message, None, tb)
    err = cls.__new__(cls)
    Exception.__init__(err, message)
    err.__dict__.update(attrs)
    err.worker_traceback = tb
    return err


def _warm_up():
    """Open the device and compile a tiny pipeline (loads the compiler before the limits are set)."""
    from .adapter import ensure_device

    device = ensure_device()
    module = device.create_shader_module(code="@compute @workgroup_size(1) fn main() {}")
    device.create_compute_pipeline(layout="auto", compute={"module": module, "entry_point": "main"})


def worker_main():
    """The worker process's loop (started by :class:`IsolatedWorker`; not for direct use).
    Reads (function, args, kwargs) frames on stdin, answers ("ok", result), ("error",
    exception) or ("lost", message) on the original stdout; anything printed goes to stderr."""
    parent = os.getppid()

    def orphaned():  # the kernel died (even killed): a compile that never ends must not outlive it
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os.kill(os.getpid(), signal.SIGKILL)

    threading.Thread(target=orphaned, name="grasswidget-worker-orphaned", daemon=True).start()
    proto = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # prints of user code or libraries must not corrupt the frames
    sys.stdout = sys.stderr
    requests = sys.stdin.buffer
    try:
        _warm_up()
    except NoGPUAdapterError as err:
        _send(proto, ("noadapter", str(err)))
        return
    except Exception as err:  # noqa: BLE001 - reported to the kernel
        _send(proto, ("error", _pack_exception(err)))
        return
    from .adapter import is_cpu_adapter

    backstop_mb = float(os.environ.get("GRASSWIDGET_WORKER_AS_MB", "0"))
    # Only on a CPU adapter, where the "GPU" memory is this process's memory: a GPU driver may
    # reserve address space in large blocks at any time, and a grade must not fail for that.
    if backstop_mb > 0 and is_cpu_adapter():
        import resource

        limit = _own_kb("VmSize") * 1024 + int(backstop_mb * 2**20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    _send(proto, ("ready", os.getpid()))
    while True:
        message = _recv(requests)
        if message is None:  # the kernel went away
            return
        func, args, kwargs = message
        try:
            result = func(*args, **kwargs)
        except Exception as err:  # noqa: BLE001 - every failure goes back to the kernel
            if _device_lost(str(err)):  # this device is gone: the kernel ends this process
                _send(proto, ("lost", str(err)))
                return
            _send(proto, ("error", _pack_exception(err)))
            continue
        _send(proto, ("ok", result))


# ------------------------------------------------------------------ the kernel's side


class IsolatedWorker:
    """A long-lived worker process for user code, with a time and a memory limit.

    Args:
        timeout_s: seconds one :meth:`call` may take (default :data:`DEFAULT_TIMEOUT_S`,
            > 0); past it the worker is killed and the call raises IsolatedRunError.
        memory_mb: megabytes of resident memory the worker may grow by during a call above
            what it used when it became ready (default :data:`DEFAULT_MEMORY_MB`, >= 64);
            past it the worker is killed. On a CPU adapter the worker's address space is
            also limited to what it had when ready plus 4 x ``memory_mb`` (``RLIMIT_AS``), so
            one huge allocation fails inside it.

    The process starts on the first call and is reused by the next ones; after a crash,
    a limit or a lost device the next call starts a new one. Thread-safe (one call at a
    time). :meth:`close` ends it; the interpreter's exit does too.
    """

    def __init__(self, timeout_s: float = DEFAULT_TIMEOUT_S, memory_mb: float = DEFAULT_MEMORY_MB):
        self.set_limits(timeout_s, memory_mb)
        self._proc = None
        self._err_file = None
        self._buffer = b""
        self._lock = threading.Lock()
        self._base_rss_kb = 0
        #: How many worker processes this object has started (1 after the first call; more after failures).
        self.starts = 0
        self._passed = set()
        atexit.register(self.close)

    def __repr__(self):
        state = f"pid {self._proc.pid}" if self.alive else "not running"
        return f"<IsolatedWorker {state}, {self.timeout_s:g} s, {self.memory_mb:g} MB, started {self.starts}x>"

    def set_limits(self, timeout_s=None, memory_mb=None):
        """Change the time limit (seconds, > 0) and/or memory limit (MB, >= 64); None keeps
        one. A new memory limit applies from the next worker process."""
        for name, value, low in (("timeout_s", timeout_s, 0.0), ("memory_mb", memory_mb, 64.0)):
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > low or value != value:
                bound = "> 0" if low == 0 else f">= {low:g}"
                raise GrassValueError(f"{name} must be a number {bound}; got {value!r}")
        if timeout_s is not None:
            self.timeout_s = float(timeout_s)
        if memory_mb is not None:
            self.memory_mb = float(memory_mb)

    @property
    def alive(self) -> bool:
        """Whether the worker process is running."""
        return self._proc is not None and self._proc.poll() is None

    @property
    def pid(self):
        """The worker process's id, or None when none runs."""
        return self._proc.pid if self.alive else None

    # ------------------------------------------------------------------ process

    def _start(self):
        env = dict(os.environ)
        env[WORKER_ENV] = "1"
        env["GRASSWIDGET_WORKER_AS_MB"] = str(4 * self.memory_mb)
        package_root = str(Path(__file__).resolve().parents[2])
        env["PYTHONPATH"] = os.pathsep.join([package_root] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep)
                                                              if p])
        self._err_file = tempfile.TemporaryFile()
        self._proc = subprocess.Popen(
            [sys.executable, "-c", "from grasswidget.gpu.isolation import worker_main; worker_main()"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._err_file, env=env, start_new_session=True)
        self._buffer = b""
        self.starts += 1
        try:
            kind, value = self._wait(START_TIMEOUT_S, "starting the isolated worker", watch_memory=False)
        except IsolatedRunError as err:  # not the user's code: no adapter in a child, a broken install...
            raise IsolatedRunError(f"the isolated worker could not start: {err.verdict}\n{err.detail}", "start",
                                   f"could not start ({err.verdict})", err.limit, err.detail) from None
        if kind == "noadapter":
            self._stop()
            raise NoGPUAdapterError(value)
        if kind == "error":
            self._stop()
            raise _unpack_exception(value)
        self._base_rss_kb = _status_kb(self._proc.pid, "VmRSS") or 0

    def _stop(self):
        proc, self._proc = self._proc, None
        if proc is not None:
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except OSError:
                    proc.kill()
            proc.wait()
            for stream in (proc.stdin, proc.stdout):
                try:
                    stream.close()
                except OSError:
                    pass
        if self._err_file is not None:
            self._err_file.close()
            self._err_file = None

    def close(self):
        """End the worker process (a later call starts a new one)."""
        with self._lock:
            self._stop()

    def _stderr_tail(self, n=600):
        if self._err_file is None:
            return ""
        try:
            self._err_file.seek(0, os.SEEK_END)
            size = self._err_file.tell()
            self._err_file.seek(max(0, size - n))
            return self._err_file.read().decode("utf-8", "replace").strip()
        except OSError:
            return ""

    def _fail(self, cause, verdict, limit, what):
        detail = self._stderr_tail()
        self._stop()
        return IsolatedRunError(f"{what}: {verdict} (in the isolated worker; the kernel is unaffected)", cause,
                                verdict, limit, detail)

    def _wait(self, timeout_s, what, watch_memory=True):
        """The next frame from the worker within ``timeout_s``; kills it and raises
        IsolatedRunError past the time or memory limit, or when it dies."""
        proc = self._proc
        fd = proc.stdout.fileno()
        start = time.monotonic()
        peak_kb = 0
        limit_kb = self.memory_mb * 1024
        try:
            while True:
                if len(self._buffer) >= _HEADER.size:
                    (n,) = _HEADER.unpack(self._buffer[:_HEADER.size])
                    if len(self._buffer) >= _HEADER.size + n:
                        frame = self._buffer[_HEADER.size:_HEADER.size + n]
                        self._buffer = self._buffer[_HEADER.size + n:]
                        return pickle.loads(frame)
                ready, _, _ = select.select([fd], [], [], _POLL_S)
                if ready:
                    chunk = os.read(fd, 1 << 20)
                    if chunk:
                        self._buffer += chunk
                        continue
                    code = proc.wait()
                    grew = f"after growing by {peak_kb / 1024:.0f} MB" if peak_kb > 0.5 * limit_kb else ""
                    # Grown past half the limit and then dead, other than by a segmentation fault: an
                    # allocation refused (RLIMIT_AS) between two looks at its size. A segmentation fault
                    # is a crash however much it grew first: on the GPU machine a recursion 50,000 deep
                    # grew the worker by 128 MB before it faulted.
                    if watch_memory and grew and code != -signal.SIGSEGV:
                        raise self._fail("memory", f"exceeded the {self.memory_mb:g} MB memory limit "
                                         f"(grew by {peak_kb / 1024:.0f} MB, then died)", self.memory_mb, what)
                    if code < 0:
                        try:
                            name = signal.Signals(-code).name
                        except ValueError:
                            name = f"signal {-code}"
                        verdict = ("crashed the shader compiler (segmentation fault" + (f", {grew})" if grew else ")")
                                   if name == "SIGSEGV" else f"crashed the worker ({name})")
                    else:
                        verdict = f"crashed the worker (exit status {code})"
                    raise self._fail("crash", verdict, None, what)
                if watch_memory:
                    rss = _status_kb(proc.pid, "VmRSS")
                    if rss is not None:
                        peak_kb = max(peak_kb, rss - self._base_rss_kb)
                        if peak_kb > limit_kb:
                            raise self._fail("memory", f"exceeded the {self.memory_mb:g} MB memory limit",
                                             self.memory_mb, what)
                if time.monotonic() - start > timeout_s:
                    raise self._fail("time", f"exceeded the {timeout_s:g} s time limit", timeout_s, what)
        except KeyboardInterrupt:  # the worker's state is unknown: start afresh next time
            self._stop()
            raise

    # ------------------------------------------------------------------ calls

    def call(self, func, *args, what: str = "the code", timeout_s=None, **kwargs):
        """``func(*args, **kwargs)`` in the worker (``func`` and the arguments picklable:
        a module-level function); its result, or the exception it raised (the same class,
        message and attributes). ``what`` names the work in an error. ``timeout_s``
        overrides the time limit for this call. Raises
        :class:`~grasswidget.errors.IsolatedRunError` when the worker crashed, ran past a
        limit or lost its device (then the next call starts a new worker), and
        :class:`~grasswidget.errors.NoGPUAdapterError` when the worker finds no adapter."""
        limit = self.timeout_s if timeout_s is None else float(timeout_s)
        try:
            frame = self._frame((func, args, kwargs))
        except Exception as err:  # noqa: BLE001 - a lambda, a local class, an open file...
            raise GrassTypeError(f"func and its arguments must be picklable to run in the isolated worker (a "
                                 f"module-level function, plain data); {what}: {err}") from None
        with self._lock:
            if not self.alive:
                self._stop()
                self._start()
            try:
                self._proc.stdin.write(frame)
                self._proc.stdin.flush()
            except (BrokenPipeError, OSError):
                raise self._fail("crash", "crashed the worker (it was gone)", None, what) from None
            kind, value = self._wait(limit, what)
            if kind == "ok":
                return value
            if kind == "lost":
                raise self._fail("device lost", f"lost the GPU device ({value.strip().splitlines()[-1][:200]})",
                                 None, what)
            raise _unpack_exception(value)

    @staticmethod
    def _frame(obj):
        data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
        return _HEADER.pack(len(data)) + data

    def check_compute(self, wgsl: str, entry_point="main", timeout_s=None):
        """Compile compute shader ``wgsl`` (module and pipeline, layout "auto", for
        ``entry_point``: a name or a tuple of names) in the
        worker: None when it compiled, the compiler's message (str) when it does not;
        raises IsolatedRunError when the compile crashed, hung, ran out of memory or lost
        the device. ``timeout_s`` overrides the time limit for this compile. Shaders that
        compiled are remembered by their text and not compiled again."""
        entries = (entry_point,) if isinstance(entry_point, str) else tuple(entry_point)
        key = hashlib.sha1((",".join(entries) + "\0" + wgsl).encode()).hexdigest()
        if key in self._passed:
            return None
        message = self.call(compile_compute, wgsl, entry_point, what="compiling the shader", timeout_s=timeout_s)
        if message is None:
            self._passed.add(key)
        return message


def compile_compute(wgsl: str, entry_point="main"):
    """Compile compute shader ``wgsl`` (module and a pipeline with layout "auto" for
    ``entry_point``, a name or a tuple of names) on this process's device: None when it
    compiled, the compiler's message when it does not. Meant for the worker (see
    :func:`check_compute`); a lost device raises."""
    import wgpu

    from .adapter import ensure_device

    device = ensure_device()
    entries = (entry_point,) if isinstance(entry_point, str) else tuple(entry_point)
    try:
        module = device.create_shader_module(code=wgsl)
        for entry in entries:
            device.create_compute_pipeline(layout="auto", compute={"module": module, "entry_point": entry})
    except wgpu.GPUError as err:
        if _device_lost(str(err)):
            raise
        return str(err)
    return None


_SHARED = {"worker": None}


def shared_worker() -> IsolatedWorker:
    """The process-wide :class:`IsolatedWorker` (created on first use, default limits)."""
    if _SHARED["worker"] is None:
        _SHARED["worker"] = IsolatedWorker()
    return _SHARED["worker"]


def set_limits(timeout_s=None, memory_mb=None):
    """Set the shared worker's time limit (seconds per call, > 0) and memory limit (MB, >= 64)."""
    shared_worker().set_limits(timeout_s, memory_mb)


def check_compute(wgsl: str, entry_point="main", worker=None):
    """Compile compute shader ``wgsl`` away from the kernel first: in ``worker`` (default
    the shared one), or directly inside a worker process. None when it compiled, the
    compiler's message when it does not; IsolatedRunError when the compile crashed, hung,
    ran out of memory or lost the device."""
    if in_worker():
        return None  # this process is the isolation: the caller compiles directly
    return (worker or shared_worker()).check_compute(wgsl, entry_point)


_HINTS = {
    "crash": "a very long or deeply nested expression is the usual cause: split it with `let`",
    "time": "a compile or pass this slow usually comes from an array indexed by a computed index (a CPU "
            "adapter's compiler is slow on those) or from helpers that call each other many times over",
    "memory": "large arrays, or helpers called many times over, are the usual cause",
    "device lost": "a huge constant or private array is the usual cause",
}


def verdict_message(err, label: str) -> str:
    """The message for :class:`~grasswidget.errors.IsolatedRunError` ``err`` about user
    code named ``label`` (e.g. "your forces code", "wind_wgsl"): the verdict, that it
    ran isolated (the kernel and its widgets are unaffected) and the usual cause."""
    hint = _HINTS.get(err.cause, "")
    return (f"{label} {err.verdict}; it ran in an isolated worker process, so the kernel, its GPU device and its "
            f"widgets are unaffected" + (f" ({hint})" if hint else ""))


#: The entry point :func:`probe_entry` adds.
PROBE_ENTRY = "isolation_probe"
_SCALARS = {"f32": "x", "i32": "i32(gid.x)", "u32": "gid.x", "bool": "(gid.x == 3u)"}


def _probe_arg(ptype, k):
    x = f"(x + {0.25 * (k + 1):.2f})"
    if ptype in _SCALARS:
        return _SCALARS[ptype].replace("x", x) if ptype == "f32" else _SCALARS[ptype]
    if ptype.startswith("vec") and ptype.endswith("<f32>"):
        n = int(ptype[3])
        return f"{ptype}({', '.join(f'{x} + {c}.0' for c in range(n))})"
    if ptype == "mat4x4<f32>":
        return f"mat4x4<f32>({', '.join(f'{x} * {c + 1}.0' for c in range(16))})"
    return None


def _probe_bits(expr, rtype, structs):
    if rtype in ("f32", "i32"):
        return f"bitcast<u32>({expr})"
    if rtype == "u32":
        return expr
    if rtype == "bool":
        return f"select(0u, 1u, {expr})"
    if rtype.startswith("vec") and rtype.endswith("<f32>"):
        return " ^ ".join(f"bitcast<u32>({expr}.{c})" for c in "xyzw"[: int(rtype[3])])
    if rtype in structs:
        return " ^ ".join(f"({_probe_bits(f'{expr}.{name}', ftype, structs)})" for name, ftype in structs[rtype])
    return "0u"


def probe_entry(functions, code: str) -> str:
    """WGSL to append to shader ``code``: a compute entry point :data:`PROBE_ENTRY` that
    calls each of ``functions`` ((name, parameter types, return type) tuples) with
    arguments the compiler cannot know in advance and stores what they return, so that a
    pipeline for it compiles every one of them (a driver compiles only what an entry point
    reaches: the culling functions are not reached from the simulation's ``main``).
    Functions with a parameter type other than scalars, float vectors and mat4x4 are left out."""
    import re

    structs = {m.group(1): [tuple(x.strip() for x in f.split(":")) for f in m.group(2).split(",") if f.strip()]
               for m in re.finditer(r"struct (\w+)\s*\{([^}]*)\}", code)}
    lines = []
    for name, params, returns in functions:
        args = [_probe_arg(t, k) for k, t in enumerate(params)]
        if any(a is None for a in args):
            continue
        call = f"{name}({', '.join(args)})"
        lines.append(f"    acc = acc ^ ({_probe_bits(call, returns, structs)});" if returns else f"    {call};")
    return ("\n@group(1) @binding(0) var<storage, read_write> isolation_probe_out: array<u32>;\n"
            f"@compute @workgroup_size(1)\nfn {PROBE_ENTRY}(@builtin(global_invocation_id) gid: vec3<u32>) {{\n"
            "    let x = f32(gid.x) * 0.001;\n    var acc = 0u;\n" + "\n".join(lines) +
            "\n    isolation_probe_out[gid.x] = acc;\n}\n")
