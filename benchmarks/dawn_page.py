"""A page for the browser engine without a browser: node + Dawn running the engine's ES module
(``benchmarks/dawn/serve_engine.mjs``), with this Python process as its kernel.

The widget is the real one (``GrassWidget(..., backend="browser")``): its engine widget's comm is
a :class:`PipeComm`, which carries the Jupyter widget protocol's comm messages (the state at open,
trait updates, custom messages, binary buffers in base64) to node over stdin and brings the
engine's back over stdout (its stats, ``gpu_status``, answers), where ipywidgets hands them to the
widget as a kernel would. So everything Python decides for the engine is decided by the same code
as in a notebook: above all the "auto" switches (:mod:`grasswidget.browser.trial_feed`: the
trial fed by the engine's frame times, the decision sent back as the ``u_cull`` words engine.js
executes). Messages are handled on the thread that calls :meth:`DawnPage.pump` (a reader thread
only queues them), as a kernel handles comm messages between cells.

:class:`DawnPage` is also the *page* :func:`benchmarks.browser_matrix.run_matrix` drives.
"""

from __future__ import annotations

import base64
import json
import os
import queue
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from comm.base_comm import BaseComm

ROOT = Path(__file__).resolve().parents[1]
SERVER = ROOT / "benchmarks" / "dawn" / "serve_engine.mjs"
#: Lines of node's stderr kept for an error message.
STDERR_TAIL = 60


def _b64(buffers) -> list:
    return [base64.b64encode(bytes(b)).decode("ascii") for b in (buffers or ())]


def _split_buffers(state: dict):
    """(state without its binary values, their paths, the binary values): the widget protocol's
    buffer_paths for this widget's traits (binary values sit at the top level: Bytes traits)."""
    plain, paths, buffers = {}, [], []
    for key, value in state.items():
        if isinstance(value, (bytes, bytearray, memoryview)):
            paths.append([key])
            buffers.append(value)
        else:
            plain[key] = value
    return plain, paths, buffers


class PipeComm(BaseComm):
    """A widget's comm to a :class:`DawnPage` (what the kernel's comm is to a notebook's page)."""

    def __init__(self, dawn_page, **kwargs):
        self.dawn_page = dawn_page
        super().__init__(**kwargs)

    def publish_msg(self, msg_type, data=None, metadata=None, buffers=None, **keys):
        op = {"comm_open": "open", "comm_msg": "msg", "comm_close": "close"}[msg_type]
        self.dawn_page.write({"op": op, "comm_id": self.comm_id, "data": data or {}, "buffers": _b64(buffers)})


class DawnPage:
    """node + Dawn serving the engine module (see the module docstring).

    Args:
        dawn: the unpacked npm package ``webgpu`` (``index.js`` and ``dist/linux-x64/dawn.node``).
        env: the environment of node (e.g. ``VK_ICD_FILENAMES`` for SwiftShader or NVIDIA's driver).
        node: the node binary (default: ``node`` on the PATH).
        start_timeout_s: seconds to wait for Dawn's adapter (default 120).
    """

    def __init__(self, dawn, env=None, node=None, start_timeout_s: float = 120.0):
        from grasswidget.browser.esm import engine_module_text

        node = node or shutil.which("node") or shutil.which("nodejs")
        if node is None:
            raise SystemExit("node is needed (Debian's nodejs, or a carried binary: --node)")
        self._folder = Path(tempfile.mkdtemp(prefix="gw-dawn-page-"))
        engine = self._folder / "engine.mjs"
        engine.write_text(engine_module_text(), encoding="utf-8")  # the module the anywidget loads (its _esm)
        self._incoming: queue.Queue = queue.Queue()
        self._stderr: list = []
        self._comms: dict = {}
        self._answers: dict = {}
        self._ids = iter(range(1, 1 << 62))
        self._lock = threading.Lock()
        self.widget = None
        self.process = subprocess.Popen([node, str(SERVER), "--engine", str(engine), "--dawn", str(dawn)],
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                        env=dict(os.environ if env is None else env), bufsize=0)
        threading.Thread(target=self._read_stdout, daemon=True).start()
        threading.Thread(target=self._read_stderr, daemon=True).start()
        self.ready = self._wait_op("ready", start_timeout_s)

    # ------------------------------------------------------------------ the pipe

    def _read_stdout(self):
        for line in self.process.stdout:
            if line.startswith(b"@gw "):
                self._incoming.put(json.loads(line[4:]))
            else:
                sys.stdout.write(line.decode("utf-8", "replace"))
        self._incoming.put({"op": "exited"})

    def _read_stderr(self):
        for line in self.process.stderr:
            self._stderr = (self._stderr + [line.decode("utf-8", "replace").rstrip()])[-STDERR_TAIL:]

    def write(self, message: dict):
        """One message to node (a line of JSON)."""
        data = (json.dumps(message) + "\n").encode("utf-8")
        with self._lock:
            try:
                self.process.stdin.write(data)
                self.process.stdin.flush()
            except BrokenPipeError:
                raise RuntimeError(f"the Dawn page exited: {self._failure()}") from None

    def _failure(self) -> str:
        return "\n".join(self._stderr[-20:]) or f"exit code {self.process.poll()}"

    def _handle(self, m: dict):
        op = m.get("op")
        if op == "msg":
            comm = self._comms.get(m["comm_id"])
            if comm is not None:  # as the kernel delivers a comm_msg to the widget
                buffers = [base64.b64decode(b) for b in m.get("buffers") or ()]
                comm.handle_msg({"content": {"comm_id": m["comm_id"], "data": m["data"]}, "buffers": buffers})
        elif op == "info":
            self._answers[m["id"]] = m["info"]
        elif op == "error":
            raise RuntimeError(f"the Dawn page failed: {m['message']}")
        elif op == "exited":
            raise RuntimeError(f"the Dawn page exited: {self._failure()}")
        else:
            self._answers[op] = m

    def pump(self, seconds: float = 0.0):
        """Handle node's messages for ``seconds`` (at least those already queued)."""
        end = time.monotonic() + seconds
        while True:
            try:
                self._handle(self._incoming.get(timeout=max(0.0, end - time.monotonic())))
            except queue.Empty:
                return

    def _wait_op(self, key, timeout_s):
        end = time.monotonic() + timeout_s
        while key not in self._answers:
            if time.monotonic() > end:
                raise TimeoutError(f"no '{key}' from the Dawn page in {timeout_s} s: {self._failure()}")
            try:
                self._handle(self._incoming.get(timeout=min(0.5, max(0.0, end - time.monotonic()))))
            except queue.Empty:
                pass
        return self._answers.pop(key)

    # ------------------------------------------------------------------ widgets

    def connect(self, widget):
        """Show an anywidget here: its comm becomes a :class:`PipeComm` (the open message carries its
        state); from now on its trait changes and messages reach the engine and the engine's reach it."""
        state, paths, buffers = _split_buffers(widget.get_state())
        comm = PipeComm(self, target_name="jupyter.widget", data={"state": state, "buffer_paths": paths},
                        buffers=buffers, metadata={})
        self._comms[comm.comm_id] = comm
        widget.comm = comm  # ipywidgets registers the widget's handler of comm messages
        return comm

    def info(self, timeout_s: float = 60.0):
        """The newest engine's counters (serve_engine.mjs's info()), messages handled meanwhile."""
        rid = next(self._ids)
        self.write({"op": "info", "id": rid})
        return self._wait_op(rid, timeout_s)

    def poll(self, check, what, timeout, interval=0.2):
        """``check()``'s first truthy value, node's messages handled in between; TimeoutError naming ``what``."""
        end = time.monotonic() + timeout
        while True:
            value = check()
            if value:
                return value
            if time.monotonic() > end:
                raise TimeoutError(f"timed out after {timeout} s waiting for {what}")
            self.pump(interval)

    # ------------------------------------------------------------------ the matrix's page (benchmarks.browser_matrix)

    def show(self, preset, n, size):
        import grasswidget as gw

        self.widget = gw.GrassWidget(n, preset=preset, backend="browser", size=tuple(size))
        engine_widget = self.widget.view.engine_widget
        self.connect(engine_widget)
        status = self.poll(lambda: engine_widget.gpu_status.get("state"), "the engine to start", 600)
        if status != "ok":
            raise RuntimeError(f"the engine did not start: {engine_widget.gpu_status}")

    def apply(self, occlusion, raster):
        self.widget.params.cull_occlusion = occlusion
        self.widget.params.compute_raster = raster

    def auto_state(self):
        switches = self.widget.view.engine_widget.auto_switches
        return switches.state.measuring, switches.texts()

    def engine(self):
        return self.info()

    def hide(self):
        if self.widget is not None:
            self.widget.close()  # the engine widget's comm closes: node removes its view and engine
            self.widget = None
        self.pump(0.2)

    def close(self):
        """Stop node (the widgets' engines close with it)."""
        if self.process.poll() is None:
            try:
                self.write({"op": "exit"})
                self.process.wait(timeout=30)
            except (RuntimeError, subprocess.TimeoutExpired):
                self.process.kill()
                self.process.wait()
        shutil.rmtree(self._folder, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
