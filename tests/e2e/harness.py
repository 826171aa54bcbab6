"""Real-browser test harness: JupyterLab + Debian's Chromium, driven by Playwright.

Everything here is synchronous (Playwright's sync API) and pytest-friendly.
A typical test::

    from tests.e2e.harness import *   # or: from .harness import ...

    write_notebook(root / "nb.ipynb", ["import ...", "widget"])
    with JupyterLabServer(root) as server, Browser() as browser:
        page = browser.page
        open_notebook(page, server, "nb.ipynb")
        run_all_cells(page)
        wait_for_frames(page, 5, timeout=30)
        set_slider(page, panel_label("gravity"), 25)
        wait_for_kernel(page, "s.value", 25.0)

Design rules:

* No sleep stands in for a check. Every ``wait_*`` polls a condition until
  it holds or a timeout expires, and then raises :class:`HarnessTimeout`
  saying what did not happen and what was last observed.
  (The only fixed-time waits are the pacing of a mouse drag, which must move
  at human speed, and the measuring window of :func:`frames_per_second`.)
* Processes are started and stopped by PID: the JupyterLab server (and the
  kernels it started, found by walking ``/proc`` from the server's PID).
* Each server and browser gets fresh private state directories, so nothing
  from ``~/.jupyter`` or a previous run leaks in.

The jupyter-rfb view is ``div.renderview-wrapper > img.renderview-view``;
every frame is a new ``blob:`` URL in the img's ``src``. Frames are counted
with a MutationObserver (see :func:`install_frame_counter`). While frames
flow they are JPEG; about 0.3 s after the last one a lossless PNG follows,
so call :func:`wait_until_quiet` before comparing pixels exactly.
"""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Optional, Sequence

__all__ = [
    "HarnessError",
    "HarnessTimeout",
    "CellExecutionError",
    "KernelExecutionError",
    "CHROMIUM_PATH",
    "CHROMIUM_ARGS",
    "WEBGPU_ARGS",
    "prerequisites_missing",
    "poll",
    "write_notebook",
    "JupyterLabServer",
    "SERVER_APPS",
    "StaticServer",
    "Browser",
    "open_notebook",
    "leave_notebook",
    "run_all_cells",
    "wait_for_kernel_idle",
    "kernel_execute",
    "kernel_eval",
    "wait_for_kernel",
    "install_frame_counter",
    "frame_count",
    "wait_for_frames",
    "frames_per_second",
    "wait_until_quiet",
    "wait_for_view",
    "view_locator",
    "view_pixels",
    "view_screenshot",
    "drag",
    "set_slider",
    "slider_readout",
    "click_button",
    "toggle_checkbox",
    "cell_output_text",
    "wait_for_output_text",
    "save_debug_artifacts",
    "KernelResult",
]

#: Debian's Chromium; override with the GW_CHROMIUM environment variable.
CHROMIUM_PATH = os.environ.get("GW_CHROMIUM", "/usr/bin/chromium")

#: Flags measured to work on this closed network. Without the networking
#: flags Chromium stalls; the backgrounding flags keep requestAnimationFrame
#: and timers running at full rate in a headless, never-focused window.
CHROMIUM_ARGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-background-timer-throttling",
    "--disable-renderer-backgrounding",
    "--disable-backgrounding-occluded-windows",
)

#: Flags that give headless Chromium a WebGPU adapter (SwiftShader, on the CPU).
#: ``--use-angle=swiftshader`` makes screenshots show the WebGPU canvas. With
#: them, ``Browser(webgpu=True)`` also leaves out ``--disable-gpu``: with it a
#: canvas renders, but every queue promise afterwards (onSubmittedWorkDone,
#: mapAsync) rejects with "A valid external Instance reference no longer exists".
WEBGPU_ARGS = (
    "--enable-unsafe-webgpu",
    "--enable-features=Vulkan",
    "--use-vulkan=swiftshader",
    "--use-webgpu-adapter=swiftshader",
    "--use-angle=swiftshader",
)


# --------------------------------------------------------------------------
# Errors and polling
# --------------------------------------------------------------------------


class HarnessError(RuntimeError):
    """Something in the browser/Jupyter setup is not as expected."""


class HarnessTimeout(HarnessError, TimeoutError):
    """A condition that was waited for did not happen in time."""


class CellExecutionError(HarnessError):
    """A notebook cell raised while running (carries ename/evalue/traceback)."""


class KernelExecutionError(HarnessError):
    """Code sent with :func:`kernel_execute` raised in the kernel."""

    def __init__(self, message: str, ename: str = "", evalue: str = "", traceback: str = ""):
        super().__init__(message)
        self.ename, self.evalue, self.traceback = ename, evalue, traceback


_ANSI_RE = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


def _strip_ansi(text: str) -> str:
    return _ANSI_RE.sub("", text)


def poll(
    check: Callable[[], Any],
    what: str,
    timeout: float,
    interval: float = 0.1,
    page=None,
    describe: Optional[Callable[[Any], str]] = None,
):
    """Call ``check()`` until it returns a truthy value, and return that value.

    ``check`` may also return a tuple ``(ok, observed)``; then ``observed`` is
    what the error message reports as last seen and is what gets returned.

    Raises :class:`HarnessTimeout` after ``timeout`` seconds, naming ``what``
    (phrase it as the condition, e.g. "5 new frames in the view") and the
    last observed value. With ``page`` given, the pause between tries is
    ``page.wait_for_timeout`` so Playwright keeps processing events.
    """
    deadline = time.monotonic() + timeout
    last: Any = None
    last_exc: Optional[BaseException] = None
    while True:
        try:
            res = check()
            last_exc = None
        except (HarnessTimeout, KeyboardInterrupt):
            raise
        except Exception as exc:  # keep polling, but remember why it failed
            res, last_exc = None, exc
        if isinstance(res, tuple) and len(res) == 2 and isinstance(res[0], bool):
            ok, observed = res
            last = observed
            if ok:
                return observed
        else:
            last = res
            if res:
                return res
        if time.monotonic() >= deadline:
            seen = describe(last) if describe else repr(last)
            msg = f"Timed out after {timeout:.1f} s waiting for {what}; last observed: {seen}"
            if last_exc is not None:
                msg += f" (last check raised {type(last_exc).__name__}: {last_exc})"
            raise HarnessTimeout(msg)
        if page is not None:
            page.wait_for_timeout(interval * 1000)
        else:
            time.sleep(interval)


def prerequisites_missing() -> Optional[str]:
    """Return why a browser test cannot run here, or None if it can."""
    if not os.path.exists(CHROMIUM_PATH):
        return f"{CHROMIUM_PATH} not found (apt-get install -y chromium)"
    for mod in ("playwright", "jupyterlab", "ipykernel", "nbformat"):
        try:
            __import__(mod)
        except ImportError:
            return f"python package {mod!r} not installed"
    return None


def write_notebook(path, cells: Sequence[str], kernel_name: str = "python3") -> Path:
    """Write a notebook of code cells (strings; a string starting with
    ``"#md "`` becomes a markdown cell with the rest as text) and return its
    path. The kernelspec is set so JupyterLab does not ask for a kernel."""
    import nbformat

    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": kernel_name, "display_name": "Python 3", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    for src in cells:
        if src.startswith("#md "):
            nb.cells.append(nbformat.v4.new_markdown_cell(src[4:]))
        else:
            nb.cells.append(nbformat.v4.new_code_cell(src))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, str(path))
    return path


# --------------------------------------------------------------------------
# JupyterLab server
# --------------------------------------------------------------------------


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _children_of(pid: int) -> list:
    """All descendant PIDs of ``pid`` (read from /proc), deepest last."""
    by_parent: dict = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        # field 4 is ppid; the command name (field 2) may contain spaces
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        by_parent.setdefault(ppid, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        for c in by_parent.get(p, []):
            out.append(c)
            todo.append(c)
    return out


def _pid_alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
        return state != "Z"
    except OSError:
        return False


#: The Jupyter front ends :class:`JupyterLabServer` starts: JupyterLab, Jupyter
#: Notebook 7 (``/notebooks/<path>``) and Voila (``/voila/render/<path>``).
SERVER_APPS = ("lab", "notebook", "voila")

#: JupyterLab user settings written into the private config dir.
#: windowingMode "none" keeps every cell (and its widget views) in the DOM
#: even when scrolled out of view; the default "full" virtualizes cells.
DEFAULT_LAB_SETTINGS = {
    "@jupyterlab/notebook-extension:tracker": {"windowingMode": "none"},
    "@jupyterlab/apputils-extension:notification": {
        "fetchNews": "false", "checkForUpdates": False, "doNotDisturbMode": True,
    },
}

#: Lab plugins disabled through the private page_config.json.
DEFAULT_DISABLED_PLUGINS = ("@jupyterlab/apputils-extension:announcements",)


#: Kernel code that makes a used kernel like a new one for the next notebook (see
#: :meth:`JupyterLabServer.shutdown_kernels`): every grasswidget widget is closed (its view,
#: loops and GPU resources), then every other widget; the user namespace, ``Out`` and the
#: history are emptied (``reset(new_session=True)``: execution counts start at 1 again).
#: Imported modules stay imported and the GPU device stays open, as after a notebook's
#: first cell. It prints ``GW-KERNEL-RESET-OK`` only when no widget is left open.
KERNEL_RESET = r"""
def __gw_reset():
    import gc
    import ipywidgets
    shell = get_ipython()
    mine = [o for o in gc.get_objects()
            if isinstance(o, ipywidgets.Widget) and type(o).__module__.startswith('grasswidget')]
    for widget in mine:
        widget.close()
    ipywidgets.Widget.close_all()
    shell.reset(new_session=True)
    gc.collect()
    from ipywidgets.widgets.widget import _instances
    if not _instances:
        print('GW-KERNEL-RESET-OK')
__gw_reset()
"""


class JupyterLabServer:
    """Start JupyterLab for ``root_dir`` on 127.0.0.1, a free port and a random
    token, with private config/runtime/data/IPython/XDG runtime directories.

    Use as a context manager (or call :meth:`start` / :meth:`stop`)::

        with JupyterLabServer(tmp_path) as server:
            page.goto(server.url_for("nb.ipynb"))

    The venv's lab extensions and kernelspecs are still found: they live in
    ``sys.prefix/share/jupyter``, which Jupyter always searches in addition to
    ``JUPYTER_DATA_DIR``. The server runs with ``python`` (default: the
    interpreter running the tests), and kernelspecs whose argv starts with
    ``python`` resolve to that same interpreter.

    :meth:`stop` terminates the server by PID (SIGTERM, then SIGKILL after
    ``stop_timeout``), then does the same to any kernel process it had
    started that is still alive.

    ``app`` picks the front end (:data:`SERVER_APPS`): ``"lab"`` (JupyterLab),
    ``"notebook"`` (Jupyter Notebook 7, app exposed as ``window.jupyterapp`` too,
    so :func:`open_notebook`, :func:`run_all_cells` and :func:`kernel_execute`
    work unchanged) or ``"voila"`` (a Voila server on ``root_dir``;
    :meth:`url_for` renders a notebook: every cell runs, only outputs show, and
    there is no REST API nor ``window.jupyterapp``).
    """

    def __init__(
        self,
        root_dir,
        *,
        python: Optional[str] = None,
        startup_timeout: float = 60.0,
        stop_timeout: float = 10.0,
        extra_args: Iterable[str] = (),
        env: Optional[dict] = None,
        lab_settings: Optional[dict] = None,
        disabled_plugins: Iterable[str] = DEFAULT_DISABLED_PLUGINS,
        app: str = "lab",
        reuse_kernels: bool = False,
    ):
        if app not in SERVER_APPS:
            raise HarnessError(f"app must be one of {', '.join(SERVER_APPS)}; got {app!r}")
        self.app = app
        self.root_dir = Path(root_dir).resolve()
        self.python = python or sys.executable
        self.startup_timeout = startup_timeout
        self.stop_timeout = stop_timeout
        self.extra_args = list(extra_args)
        self.extra_env = dict(env or {})
        self.lab_settings = DEFAULT_LAB_SETTINGS if lab_settings is None else lab_settings
        self.disabled_plugins = list(disabled_plugins)
        self.token = uuid.uuid4().hex
        self.port: Optional[int] = None
        self.proc: Optional[subprocess.Popen] = None
        self.state_dir: Optional[Path] = None
        self.log_path: Optional[Path] = None
        self._log_file = None
        self.startup_seconds: Optional[float] = None
        self.reuse_kernels = reuse_kernels
        #: The session kept by :meth:`shutdown_kernels` (reset, no page connected), or None.
        self.warm_session: Optional[dict] = None
        #: How many notebooks :func:`open_notebook` opened on a kept kernel / kernels reset to keep.
        self.kernels_reused = 0
        #: With ``spare_kernels`` (and ``reuse_kernels`` off), :func:`open_notebook` starts a new kernel
        #: for the next notebook as soon as its own is open (:meth:`start_spare_kernel`).
        self.spare_kernels = False
        #: The kernel started ahead by :meth:`start_spare_kernel` (it has run nothing), or None.
        self.spare_session: Optional[dict] = None

    # -- public API --------------------------------------------------------

    @property
    def base_url(self) -> str:
        """``http://127.0.0.1:PORT/`` (with trailing slash)."""
        if self.port is None:
            raise HarnessError("JupyterLabServer is not started")
        return f"http://127.0.0.1:{self.port}/"

    @property
    def pid(self) -> Optional[int]:
        return self.proc.pid if self.proc else None

    def url_for(self, notebook_relpath: str = "") -> str:
        """URL that opens ``notebook_relpath`` (relative to root_dir) in Lab,
        token included. An empty path gives the Lab main page."""
        rel = str(notebook_relpath).lstrip("/")
        if self.app == "notebook":  # Jupyter Notebook 7: one notebook per page
            path = "notebooks/" + urllib.parse.quote(rel) if rel else "tree"
            return f"{self.base_url}{path}?token={self.token}"
        if self.app == "voila":  # Voila runs every cell, then shows the outputs alone
            path = "voila/render/" + urllib.parse.quote(rel) if rel else "voila/tree"
            return f"{self.base_url}{path}?token={self.token}"
        path = "lab/tree/" + urllib.parse.quote(rel) if rel else "lab"
        # ``reset`` drops the saved workspace, so notebooks opened by an
        # earlier test are not reopened (each would start its own kernel).
        return f"{self.base_url}{path}?reset&token={self.token}"

    def api(self, path: str, method: str = "GET", timeout: float = 5.0, body: Any = None) -> Any:
        """Call the server's REST API (``path`` like ``"api/kernels"``, ``body`` sent as
        JSON) and return the decoded JSON (None for an empty body)."""
        sep = "&" if "?" in path else "?"
        url = f"{self.base_url}{path.lstrip('/')}{sep}token={self.token}"
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(url, method=method, data=data,
                                     headers={"Content-Type": "application/json"} if data else {})
        with urllib.request.urlopen(req, timeout=timeout) as resp:
            body = resp.read()
        return json.loads(body) if body else None

    def shutdown_kernels(self, timeout: float = 15.0, keep_one: Optional[bool] = None) -> int:
        """End every notebook session through the REST API; returns how many there were.
        Navigating to another notebook does *not* stop the previous notebook's kernel;
        call this in between (after the page left the notebook).

        With ``keep_one`` (default: the server's ``reuse_kernels``), one kernel that no
        page is connected to any more is not shut down but reset (:data:`KERNEL_RESET`:
        every widget closed, the user namespace and history emptied) and kept; the next
        :func:`open_notebook` opens its notebook on it, which spares starting a kernel
        and importing the package again (about 7 s on 2 busy cores). A kernel whose
        reset fails, times out or finds a widget still open is shut down like the rest."""
        keep_one = self.reuse_kernels if keep_one is None else keep_one
        spare = (self.spare_session or {}).get("id")
        sessions = [s for s in self.api("api/sessions") if s["id"] != spare]  # the spare kernel waits on
        self.warm_session = None
        for s in sessions:
            if keep_one and self.warm_session is None and self._reset_for_reuse(s):
                self.warm_session = s
                continue
            self.api(f"api/sessions/{s['id']}", method="DELETE", timeout=timeout)
        return len(sessions)

    def drop_warm_kernel(self, timeout: float = 15.0) -> None:
        """Shut down the kernel :meth:`shutdown_kernels` kept, if any (after a failed
        test, so the next test starts on a new kernel)."""
        s, self.warm_session = self.warm_session, None
        if s is not None:
            try:
                self.api(f"api/sessions/{s['id']}", method="DELETE", timeout=timeout)
            except urllib.error.HTTPError:
                pass  # already gone

    def start_spare_kernel(self) -> None:
        """Start a new kernel now for the next notebook that wants a new one (a session of a
        placeholder notebook in the served folder's top level; nothing runs in it). It starts
        (Python, ipykernel: seconds on 2 busy cores) while the current notebook runs, and
        :func:`open_notebook` hands it to the next notebook: the kernel that notebook gets has run
        nothing, as one Lab would start for it, only started earlier. :meth:`shutdown_kernels`
        leaves it alone; :meth:`drop_spare_kernel` (or :meth:`stop`) ends it."""
        if self.spare_session is None:
            self.spare_session = self.api("api/sessions", method="POST", timeout=60, body={
                "path": f".gw-spare-{uuid.uuid4().hex}.ipynb", "name": "spare", "type": "notebook",
                "kernel": {"name": "python3"}})

    def drop_spare_kernel(self, timeout: float = 15.0) -> None:
        """Shut down the kernel :meth:`start_spare_kernel` started, if no notebook took it."""
        s, self.spare_session = self.spare_session, None
        if s is not None:
            try:
                self.api(f"api/sessions/{s['id']}", method="DELETE", timeout=timeout)
            except urllib.error.HTTPError:
                pass  # already gone

    def take_spare_session(self, relpath: str) -> Optional[dict]:
        """Hand the spare kernel (:meth:`start_spare_kernel`) to the notebook ``relpath`` when it
        lies in the served folder's top level, where the spare kernel runs (its working folder is
        the notebook's, as for a kernel Lab starts); None otherwise (Lab starts one)."""
        if self.spare_session is None or Path(relpath).parent != Path("."):
            return None
        s, self.spare_session = self.spare_session, None
        try:
            return self.api(f"api/sessions/{s['id']}", method="PATCH",
                            body={"path": relpath, "name": Path(relpath).name, "type": "notebook"})
        except urllib.error.HTTPError:
            return None  # the kernel died meanwhile: Lab starts a new one

    def take_warm_session(self, relpath: str) -> Optional[dict]:
        """Hand the kept kernel to the notebook ``relpath`` (its session is renamed to that
        path, so Lab opening the notebook connects to it); None when none is kept."""
        s, self.warm_session = self.warm_session, None
        if s is None:
            return None
        try:
            moved = self.api(f"api/sessions/{s['id']}", method="PATCH",
                             body={"path": relpath, "name": Path(relpath).name, "type": "notebook"})
        except urllib.error.HTTPError:
            return None  # the kernel died meanwhile: Lab starts a new one
        self.kernels_reused += 1
        return moved

    def _reset_for_reuse(self, session: dict, timeout: float = 15.0) -> bool:
        kernel = session.get("kernel") or {}
        if kernel.get("name") != "python3":
            return False
        # the page that used it must have let go (it navigated away): wait for its socket to close
        def released():
            k = self.api(f"api/kernels/{kernel['id']}")
            return k.get("connections", 0) == 0 and k.get("execution_state") == "idle", k
        try:
            poll(released, "the kernel to have no page connected and be idle", 5.0, 0.1)
        except (HarnessTimeout, urllib.error.URLError, OSError):
            return False
        connection_file = self.state_dir / "runtime" / f"kernel-{kernel['id']}.json"
        if not connection_file.exists():
            return False
        from jupyter_client import BlockingKernelClient

        client = BlockingKernelClient(connection_file=str(connection_file))
        client.load_connection_file()
        client.start_channels()
        printed = []
        try:
            reply = client.execute_interactive(
                KERNEL_RESET, store_history=False, timeout=timeout,
                output_hook=lambda msg: printed.append(msg["content"].get("text", ""))
                if msg["header"]["msg_type"] == "stream" else None)
            return reply["content"]["status"] == "ok" and "GW-KERNEL-RESET-OK" in "".join(printed)
        except Exception:  # a busy or broken kernel is not reused
            return False
        finally:
            client.stop_channels()

    def log_text(self, tail: int = 0) -> str:
        """The server's combined stdout/stderr so far (last ``tail`` chars)."""
        if not self.log_path or not self.log_path.exists():
            return ""
        text = self.log_path.read_text(errors="replace")
        return text[-tail:] if tail else text

    def start(self) -> "JupyterLabServer":
        """Start the server and wait until ``/api/status`` answers."""
        if self.proc is not None:
            raise HarnessError("JupyterLabServer already started")
        if not self.root_dir.is_dir():
            raise HarnessError(f"root_dir {self.root_dir} is not a directory")
        self.state_dir = Path(tempfile.mkdtemp(prefix="gw-lab-"))
        self._write_private_config()
        env = self._environment()
        self.log_path = self.state_dir / "server.log"
        t0 = time.monotonic()
        last_error = None
        for _attempt in range(3):  # retry only if the free port got taken meanwhile
            self.port = _free_port()
            self._log_file = open(self.log_path, "ab")
            self.proc = subprocess.Popen(
                self._command(),
                cwd=str(self.root_dir),
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=self._log_file,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
            try:
                self._wait_until_up()
                self.startup_seconds = time.monotonic() - t0
                return self
            except HarnessError as exc:
                last_error = exc
                exited = self.proc.poll() is not None
                port_taken = "address already in use" in self.log_text(4000).lower()
                self.stop()
                if not (exited and port_taken):
                    raise
        raise last_error  # type: ignore[misc]

    def stop(self) -> None:
        """Stop the server (SIGTERM, then SIGKILL) and any leftover kernels,
        by PID. Safe to call more than once."""
        proc, self.proc = self.proc, None
        if proc is not None:
            children = _children_of(proc.pid) if proc.poll() is None else []
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(self.stop_timeout)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait(5)
            # Kernels run in their own session and poll their parent; give
            # them a moment to notice, then end them by PID.
            for sig, grace in ((None, 3.0), (signal.SIGTERM, 3.0), (signal.SIGKILL, 2.0)):
                alive = [c for c in children if _pid_alive(c)]
                if not alive:
                    break
                for c in alive:
                    if sig is not None:
                        try:
                            os.kill(c, sig)
                        except ProcessLookupError:
                            pass
                deadline = time.monotonic() + grace
                while time.monotonic() < deadline and any(_pid_alive(c) for c in alive):
                    time.sleep(0.05)
        if self._log_file is not None:
            self._log_file.close()
            self._log_file = None

    def cleanup(self) -> None:
        """Remove the private state directory (logs included)."""
        if self.state_dir and self.state_dir.exists():
            shutil.rmtree(self.state_dir, ignore_errors=True)

    def __enter__(self) -> "JupyterLabServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # -- internals ---------------------------------------------------------

    def _write_private_config(self) -> None:
        sd = self.state_dir
        for sub in ("config", "runtime", "data", "ipython", "xdg-runtime"):
            (sd / sub).mkdir(mode=0o700)
        os.chmod(sd / "xdg-runtime", 0o700)
        labconfig = sd / "config" / "labconfig"
        labconfig.mkdir()
        (labconfig / "page_config.json").write_text(
            json.dumps({"disabledExtensions": {p: True for p in self.disabled_plugins}})
        )
        for plugin_id, settings in self.lab_settings.items():
            pkg, plugin = plugin_id.rsplit(":", 1)
            d = sd / "config" / "lab" / "user-settings" / pkg
            d.mkdir(parents=True, exist_ok=True)
            (d / f"{plugin}.jupyterlab-settings").write_text(json.dumps(settings))

    def _environment(self) -> dict:
        sd = self.state_dir
        env = dict(os.environ)
        env.update(
            JUPYTER_CONFIG_DIR=str(sd / "config"),
            JUPYTER_RUNTIME_DIR=str(sd / "runtime"),
            JUPYTER_DATA_DIR=str(sd / "data"),
            IPYTHONDIR=str(sd / "ipython"),
            XDG_RUNTIME_DIR=str(sd / "xdg-runtime"),
            JUPYTER_PLATFORM_DIRS="1",
            PYTHONUNBUFFERED="1",
        )
        env.pop("JUPYTER_TOKEN", None)
        env.update(self.extra_env)
        return env

    def _command(self) -> list:
        if self.app == "voila":
            return [
                self.python, "-m", "voila",
                f"--Voila.root_dir={self.root_dir}",
                "--Voila.ip=127.0.0.1",
                f"--Voila.port={self.port}",
                "--Voila.port_retries=0",
                f"--Voila.token={self.token}",
                "--Voila.open_browser=False",
                "--VoilaConfiguration.show_tracebacks=True",
                *self.extra_args,
            ]
        if self.app == "notebook":
            return [
                self.python, "-m", "notebook",
                f"--ServerApp.root_dir={self.root_dir}",
                "--ServerApp.ip=127.0.0.1",
                f"--ServerApp.port={self.port}",
                "--ServerApp.port_retries=0",
                f"--IdentityProvider.token={self.token}",
                "--ServerApp.open_browser=False",
                "--ServerApp.allow_root=True",
                "--ServerApp.terminals_enabled=False",
                "--JupyterNotebookApp.expose_app_in_browser=True",
                *self.extra_args,
            ]
        return [
            self.python, "-m", "jupyterlab",
            f"--ServerApp.root_dir={self.root_dir}",
            "--ServerApp.ip=127.0.0.1",
            f"--ServerApp.port={self.port}",
            "--ServerApp.port_retries=0",
            f"--IdentityProvider.token={self.token}",
            "--ServerApp.open_browser=False",
            "--ServerApp.allow_root=True",
            "--ServerApp.terminals_enabled=False",
            "--LabApp.expose_app_in_browser=True",
            "--LabApp.news_url=None",
            "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
            *self.extra_args,
        ]

    def _wait_until_up(self) -> None:
        # Voila answers no REST API; its notebook tree page shows it is up.
        status = "voila/tree" if self.app == "voila" else "api/status"
        url = f"{self.base_url}{status}?token={self.token}"

        def check():
            if self.proc.poll() is not None:
                raise HarnessError(
                    f"JupyterLab exited with code {self.proc.returncode} before answering.\n"
                    f"--- server log (tail) ---\n{self.log_text(3000)}"
                )
            try:
                with urllib.request.urlopen(url, timeout=2) as resp:
                    return resp.status == 200, resp.status
            except (urllib.error.URLError, ConnectionError, socket.timeout, OSError) as exc:
                return False, f"{type(exc).__name__}: {exc}"

        try:
            _poll_raising(check, f"the {self.app} server to answer {url.split('?')[0]}", self.startup_timeout, 0.2)
        except HarnessTimeout as exc:
            raise HarnessTimeout(f"{exc}\n--- server log (tail) ---\n{self.log_text(3000)}") from None


class StaticServer:
    """Serve the files of ``root_dir`` over http://127.0.0.1 (a free port), in a thread
    of this process, for pages that need a secure origin (WebGPU) but no Jupyter::

        with StaticServer(tmp_path) as static:
            page.goto(static.url_for("meadow.html"))

    ``requests`` lists the paths asked for, in order (to check a page fetches nothing).
    """

    def __init__(self, root_dir):
        self.root_dir = Path(root_dir).resolve()
        self.requests: list = []
        self._server = None
        self._thread = None

    def start(self) -> "StaticServer":
        import functools
        import http.server
        import threading

        seen = self.requests

        class Handler(http.server.SimpleHTTPRequestHandler):
            def log_message(self, *_args):
                seen.append(self.path)

        handler = functools.partial(Handler, directory=str(self.root_dir))
        self._server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)
        self._thread.start()
        return self

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self._server.server_address[1]}/"

    def url_for(self, relpath: str) -> str:
        return self.base_url + urllib.parse.quote(str(relpath).lstrip("/"))

    def stop(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._thread.join(5)
            self._server = None

    def __enter__(self) -> "StaticServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


class MarimoServer:
    """``marimo run`` (or ``edit``) of one notebook file: a token-less server on 127.0.0.1 at a free
    port, headless, its output in a log file beside the notebook. Each page opened on it starts
    a session that runs the notebook in a kernel of marimo's own (a child process)::

        with MarimoServer(tmp_path / "app.py") as marimo:
            page.goto(marimo.base_url)

    :meth:`stop` ends the server and what it started, by PID (as :class:`JupyterLabServer`).
    """

    def __init__(self, notebook, mode: str = "run", startup_timeout: float = 90.0):
        if mode not in ("run", "edit"):
            raise HarnessError(f"mode must be 'run' or 'edit'; got {mode!r}")
        self.notebook = Path(notebook).resolve()
        self.mode = mode
        self.startup_timeout = startup_timeout
        self.port = None
        self.proc = None
        self.log_path = self.notebook.with_suffix(".marimo.log")
        self._log_file = None

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    def log_text(self, tail: int = 0) -> str:
        try:
            text = self.log_path.read_text(errors="replace")
        except OSError:
            return ""
        return text[-tail:] if tail else text

    def start(self) -> "MarimoServer":
        marimo = Path(sys.executable).with_name("marimo")
        command = [str(marimo) if marimo.exists() else "marimo", "-q", self.mode, str(self.notebook), "--headless",
                   "--host", "127.0.0.1", "--no-token"]
        if self.mode == "edit":
            command.append("--skip-update-check")
        self.port = _free_port()
        command += ["--port", str(self.port)]
        env = dict(os.environ, PYTHONUNBUFFERED="1", MARIMO_SKIP_UPDATE_CHECK="1")
        self._log_file = open(self.log_path, "w")
        self.proc = subprocess.Popen(command, cwd=str(self.notebook.parent), env=env, stdout=self._log_file,
                                     stderr=subprocess.STDOUT)

        def up():
            if self.proc.poll() is not None:
                raise HarnessError(f"marimo exited with {self.proc.returncode}:\n{self.log_text(3000)}")
            try:
                socket.create_connection(("127.0.0.1", self.port), 0.5).close()
                return True
            except OSError:
                return False

        try:
            _poll_raising(up, f"marimo {self.mode} to listen on port {self.port}", self.startup_timeout, 0.2)
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        """Stop the server and its kernels (SIGTERM, then SIGKILL), by PID. Safe to call twice."""
        proc, self.proc = self.proc, None
        if proc is not None:
            children = _children_of(proc.pid) if proc.poll() is None else []
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(15)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait(5)
            for sig in (signal.SIGTERM, signal.SIGKILL):
                alive = [c for c in children if _pid_alive(c)]
                for c in alive:
                    try:
                        os.kill(c, sig)
                    except ProcessLookupError:
                        pass
                deadline = time.monotonic() + 3.0
                while time.monotonic() < deadline and any(_pid_alive(c) for c in alive):
                    time.sleep(0.05)
        if self._log_file is not None:
            self._log_file.close()
            self._log_file = None

    def __enter__(self) -> "MarimoServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def _poll_raising(check, what, timeout, interval):
    """Like :func:`poll`, but a HarnessError raised by ``check`` ends it at once."""

    def wrapped():
        try:
            return check()
        except HarnessError as exc:
            raise _Abort(exc)

    try:
        return poll(wrapped, what, timeout, interval)
    except _Abort as a:
        raise a.exc from None


class _Abort(HarnessTimeout):
    def __init__(self, exc):
        super().__init__(str(exc))
        self.exc = exc


# --------------------------------------------------------------------------
# Browser
# --------------------------------------------------------------------------


# Playwright's sync API runs one instance per process (a second one inside the
# first raises "using Playwright Sync API inside the asyncio loop"), so every
# Browser shares one, started with the first and stopped with the last.
_PLAYWRIGHT = {"cm": None, "instance": None, "users": 0}


def _acquire_playwright():
    from playwright.sync_api import sync_playwright

    if _PLAYWRIGHT["users"] == 0:
        cm = sync_playwright()
        _PLAYWRIGHT["instance"] = cm.__enter__()
        _PLAYWRIGHT["cm"] = cm
    _PLAYWRIGHT["users"] += 1
    return _PLAYWRIGHT["instance"]


def _release_playwright():
    _PLAYWRIGHT["users"] -= 1
    if _PLAYWRIGHT["users"] == 0:
        cm, _PLAYWRIGHT["cm"], _PLAYWRIGHT["instance"] = _PLAYWRIGHT["cm"], None, None
        cm.__exit__(None, None, None)


class Browser:
    """Headless Debian Chromium through Playwright (sync API), with a fresh
    user-data dir. ``.page`` is ready to use; ``.context`` can open more.

    Console messages and page errors of every page are collected in
    ``.console`` (list of strings) for diagnostics::

        with Browser() as browser:
            browser.page.goto(url)
    """

    def __init__(
        self,
        *,
        executable_path: str = CHROMIUM_PATH,
        headless: bool = True,
        viewport: tuple = (1280, 1000),
        extra_args: Iterable[str] = (),
        default_timeout: float = 30.0,
        webgpu: bool = False,
    ):
        self.executable_path = executable_path
        self.webgpu = webgpu
        self.headless = headless
        self.viewport = viewport
        self.extra_args = list(extra_args)
        self.default_timeout = default_timeout
        self.console: list = []
        self._pw_cm = None
        self.playwright = None
        self.context = None
        self.page = None
        self.user_data_dir: Optional[str] = None

    def start(self) -> "Browser":
        if not os.path.exists(self.executable_path):
            raise HarnessError(f"Chromium not found at {self.executable_path} (apt-get install -y chromium)")
        self.user_data_dir = tempfile.mkdtemp(prefix="gw-chromium-")
        self._pw_cm = True
        self.playwright = _acquire_playwright()
        try:
            self.context = self.playwright.chromium.launch_persistent_context(
                self.user_data_dir,
                executable_path=self.executable_path,
                headless=self.headless,
                args=[*self.launch_args()],
                viewport={"width": self.viewport[0], "height": self.viewport[1]},
                timeout=60_000,
            )
            self.context.set_default_timeout(self.default_timeout * 1000)
            self.context.on("page", self._watch)
            self.page = self.context.pages[0] if self.context.pages else self.context.new_page()
            self._watch(self.page)
        except BaseException:
            self.stop()
            raise
        return self

    def launch_args(self) -> list:
        """Chromium's command-line flags: CHROMIUM_ARGS (+ WEBGPU_ARGS without --disable-gpu) + extra_args."""
        if self.webgpu:
            return [*(a for a in CHROMIUM_ARGS if a != "--disable-gpu"), *WEBGPU_ARGS, *self.extra_args]
        return [*CHROMIUM_ARGS, *self.extra_args]

    def new_page(self):
        """Open another tab in the same browser."""
        return self.context.new_page()

    def _watch(self, page) -> None:
        if getattr(page, "_gw_watched", False):
            return
        page._gw_watched = True
        page.on("console", lambda m: self.console.append(f"[{m.type}] {m.text}"))
        page.on("pageerror", lambda e: self.console.append(f"[pageerror] {e}"))
        page.on("dialog", self._on_dialog)

    def _on_dialog(self, dialog) -> None:
        # JupyterLab asks "leave page?" (beforeunload) when a notebook is
        # dirty; accept it so navigating away never hangs. Other native
        # dialogs (alert/confirm/prompt) are dismissed, as Playwright would.
        self.console.append(f"[dialog:{dialog.type}] {dialog.message}")
        if dialog.type == "beforeunload":
            dialog.accept()
        else:
            dialog.dismiss()

    def stop(self) -> None:
        """Close the browser and Playwright; remove the user-data dir."""
        try:
            if self.context is not None:
                self.context.close()
        finally:
            self.context = None
            if self._pw_cm is not None:
                _release_playwright()
                self._pw_cm = None
            if self.user_data_dir:
                shutil.rmtree(self.user_data_dir, ignore_errors=True)

    def __enter__(self) -> "Browser":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


# --------------------------------------------------------------------------
# JupyterLab in the page
# --------------------------------------------------------------------------

# JS function text: find the NotebookPanel for a path (or the current one).
# Playwright's evaluate() needs a single function expression, so JS that uses
# it is built with _with_find_panel(function_text).
_JS_FIND_PANEL = r"""
function __gwFindPanel(path) {
  const app = window.jupyterapp;
  if (!app) return null;
  const isNb = (w) => w && w.sessionContext && w.content && Array.isArray(w.content.widgets) && w.context;
  const all = [];
  for (const w of app.shell.widgets('main')) { if (isNb(w)) all.push(w); }
  if (path) return all.find((w) => w.context.path === path) || null;
  const cur = app.shell.currentWidget;
  if (isNb(cur)) return cur;
  return all.length === 1 ? all[0] : null;
}
"""


def _with_find_panel(fn: str) -> str:
    return "(__gwArg) => {\n" + _JS_FIND_PANEL + "\nreturn (" + fn.strip() + ")(__gwArg);\n}"


_JS_NOTEBOOK_STATE = _with_find_panel(r"""
(path) => {
  const app = window.jupyterapp;
  if (!app) return {ok: false, why: 'window.jupyterapp is not defined yet'};
  const p = __gwFindPanel(path);
  if (!p) {
    const open = [];
    for (const w of app.shell.widgets('main')) open.push(w.context ? w.context.path : w.id);
    return {ok: false, why: 'notebook ' + path + ' is not open; main area has ' + JSON.stringify(open)};
  }
  if (!p.context.isReady) return {ok: false, why: 'document context not ready'};
  const s = p.sessionContext;
  const k = s.session && s.session.kernel;
  if (!k) return {ok: false, why: 'no kernel yet (session ' + (s.session ? 'exists' : 'missing') + ')'};
  const cells = p.content.widgets;
  let running = 0, pending = 0;
  for (const c of cells) {
    if (c.model.type !== 'code') continue;
    if (c.model.executionState === 'running') running++;
    const prompt = c.promptNode ? c.promptNode.textContent : '';
    if (prompt.includes('*')) pending++;
  }
  return {ok: true, path: p.context.path, kernelStatus: k.status, connection: k.connectionStatus,
          cells: cells.length, running, pending, id: p.id};
}
""")


def _notebook_state(page, path: Optional[str]):
    return page.evaluate(_JS_NOTEBOOK_STATE, path)


#: JS: close every document of Lab's main area without asking (marked saved first, so no
#: "save your work?" dialog), as navigating away would; returns how many were closed.
_JS_CLOSE_DOCUMENTS = r"""
() => {
  const app = window.jupyterapp;
  if (!app) return -1;
  let n = 0;
  for (const w of [...app.shell.widgets('main')]) {
    if (w.context && w.context.model) w.context.model.dirty = false;
    w.dispose();
    n++;
  }
  return n;
}
"""

#: JS: the frame counter starts again from 0, as if installed now (a notebook opened in a page
#: that already ran one counts its own frames only).
_JS_RESTART_COUNTER = "() => { const st = window.__gwFrames; if (st) { st.total = 0; st.last = performance.now(); } }"


def _shows_lab_of(page, server) -> bool:
    """The page holds ``server``'s JupyterLab app, loaded and with no dialog open."""
    if getattr(server, "app", None) != "lab" or not page.url.startswith(f"{server.base_url}lab"):
        return False
    try:
        return bool(page.evaluate("() => !!(window.jupyterapp && window.jupyterapp.shell) && "
                                  "!document.querySelector('.jp-Dialog')"))
    except Exception:  # navigating, or the page is gone
        return False


#: Kernel code closing every widget (grasswidget's first: their views, loops and GPU resources),
#: run through the page's own connection so that the page hears each close and ends the widget's
#: views and page-wide state (the browser engine's engines) as a user's ``w.close()`` would.
CLOSE_WIDGETS = r"""
def __gw_close_widgets():
    import gc
    import ipywidgets
    for widget in [o for o in gc.get_objects()
                   if isinstance(o, ipywidgets.Widget) and type(o).__module__.startswith('grasswidget')]:
        widget.close()
    ipywidgets.Widget.close_all()
__gw_close_widgets()
del __gw_close_widgets
"""

#: JS: the notebooks open in Lab's main area (their paths).
_JS_OPEN_NOTEBOOKS = r"""
() => [...window.jupyterapp.shell.widgets('main')]
  .filter((w) => w.sessionContext && w.content && w.context).map((w) => w.context.path)
"""

#: JS: every browser-engine engine of the page is closed (engine.js's page-wide registry).
_JS_ENGINES_CLOSED = r"""
() => { const e = globalThis.__grasswidgetEngines; return !e || [...e.values()].every((x) => x.closed); }
"""


def _close_in_lab(page, timeout: float = 15.0) -> bool:
    """Close the notebooks open in Lab as a user ends them: every widget closed from its kernel
    (the page ends their views and engines), then the notebook closed. False (nothing may be
    left as it was) when a kernel does not answer or something of the page stays open."""
    try:
        for path in page.evaluate(_JS_OPEN_NOTEBOOKS):
            kernel_execute(page, CLOSE_WIDGETS, path, timeout=timeout)
        poll(lambda: page.evaluate(_JS_ENGINES_CLOSED), "the page's browser engines to close", 10, 0.1, page=page)
        return page.evaluate(_JS_CLOSE_DOCUMENTS) >= 0
    except Exception:
        return False


def leave_notebook(page, server: JupyterLabServer, reload: bool = False) -> None:
    """End a test's notebook: close it in the page and end its kernel through the server
    (:meth:`JupyterLabServer.shutdown_kernels`, which keeps one kernel, reset, when the server
    reuses kernels). Where the page holds this server's JupyterLab (and ``reload`` is False) its
    widgets are closed from the kernel (:data:`CLOSE_WIDGETS`: the page ends their views and
    engines), the notebook is closed inside Lab and Lab stays loaded, so the next
    :func:`open_notebook` opens its notebook in the same app without loading Lab again (about 3 s
    on 2 busy cores); otherwise (after a failed test: ``reload=True``, or when a kernel does not
    answer or an engine stays open) the page goes to ``about:blank``, as navigating away."""
    closed = not reload and _shows_lab_of(page, server) and _close_in_lab(page)
    if not closed:
        page.goto("about:blank")
    server.shutdown_kernels()


def open_notebook(page, server: JupyterLabServer, relpath: str, timeout: float = 90.0,
                  reload: bool = False) -> None:
    """Open ``relpath`` in Lab and wait until the notebook panel is
    open, its kernel is connected and idle; installs the frame counter.
    A kernel the server kept (:meth:`JupyterLabServer.shutdown_kernels`), else the spare kernel
    it started ahead (:meth:`JupyterLabServer.start_spare_kernel`), is handed to the notebook
    first, so Lab connects to it instead of starting one. With the server's ``spare_kernels`` on
    (and ``reuse_kernels`` off), a new spare kernel is started for the next notebook once this one is open.

    Where the page already holds this server's Lab (:func:`leave_notebook` left it loaded) the
    notebook is opened inside it (``docmanager:open``), after closing any document still open
    (a notebook as :func:`leave_notebook` does), and the frame counter starts again from 0;
    otherwise (or with ``reload``, or when a browser engine of a notebook before is still open)
    the page navigates to the notebook's URL and Lab loads (with its saved workspace reset)."""
    if getattr(server, "warm_session", None) is not None:
        server.take_warm_session(relpath)
    elif getattr(server, "spare_session", None) is not None:
        server.take_spare_session(relpath)
    in_app = not reload and _shows_lab_of(page, server)
    if in_app and page.evaluate(_JS_OPEN_NOTEBOOKS):  # one still open: end it as leave_notebook does
        in_app = _close_in_lab(page)
    if in_app and not page.evaluate(_JS_ENGINES_CLOSED):  # something of a notebook before still runs
        in_app = False
    if in_app:
        page.evaluate(_JS_CLOSE_DOCUMENTS)
        page.evaluate("async (path) => { await window.jupyterapp.commands.execute('docmanager:open', "
                      "{path, factory: 'Notebook'}); }", relpath)
        page.evaluate(_JS_RESTART_COUNTER)
    else:
        page.goto(server.url_for(relpath), wait_until="domcontentloaded", timeout=timeout * 1000)

    def check():
        st = _notebook_state(page, relpath)
        ok = st.get("ok") and st["connection"] == "connected" and st["kernelStatus"] == "idle"
        return bool(ok), st

    poll(check, f"notebook {relpath!r} to open with a connected, idle kernel", timeout, 0.25, page=page)
    _activate(page, relpath)
    install_frame_counter(page)
    if getattr(server, "spare_kernels", False) and not server.reuse_kernels:
        server.start_spare_kernel()  # for the next notebook, starting while this one runs


def _activate(page, path: Optional[str]) -> None:
    page.evaluate(
        _with_find_panel("(path) => { const p = __gwFindPanel(path); if (p) window.jupyterapp.shell.activateById(p.id); }"),
        path,
    )


def wait_for_kernel_idle(page, path: Optional[str] = None, timeout: float = 60.0) -> dict:
    """Wait until no cell of the notebook is running or queued and the
    kernel reports 'idle'. Returns the last notebook state."""

    def check():
        st = _notebook_state(page, path)
        ok = bool(st.get("ok")) and st["kernelStatus"] == "idle" and st["running"] == 0 and st["pending"] == 0
        return ok, st

    return poll(check, "the kernel to be idle with no running or queued cells", timeout, 0.2, page=page)


_JS_CELL_ERRORS = _with_find_panel(r"""
(path) => {
  const p = __gwFindPanel(path);
  const errs = [];
  p.content.widgets.forEach((c, i) => {
    if (c.model.type !== 'code') return;
    for (const o of c.model.outputs.toJSON()) {
      if (o.output_type === 'error') errs.push({cell: i, ename: o.ename, evalue: o.evalue, traceback: (o.traceback || []).join('\n')});
    }
  });
  const unrun = [];
  p.content.widgets.forEach((c, i) => { if (c.model.type === 'code' && c.model.executionCount == null && c.model.sharedModel.getSource().trim()) unrun.push(i); });
  return {errs, unrun};
}
""")


def run_all_cells(
    page, path: Optional[str] = None, timeout: float = 120.0, clear_first: bool = True, raise_on_error: bool = True
) -> None:
    """Run all cells (``notebook:run-all-cells``) and wait until they are done.

    With ``raise_on_error`` a cell error raises :class:`CellExecutionError`
    with the traceback. Note: a cell displaying a continuously animating
    widget still finishes; the animation runs on the kernel's event loop."""
    _activate(page, path)
    if clear_first:
        page.evaluate("() => window.jupyterapp.commands.execute('notebook:clear-all-cell-outputs')")
    res = page.evaluate(
        """async (ms) => {
          let timer;
          const to = new Promise((res) => { timer = setTimeout(() => res('timeout'), ms); });
          try {
            const r = await Promise.race([window.jupyterapp.commands.execute('notebook:run-all-cells'), to]);
            return r === 'timeout' ? 'timeout' : 'done';
          } finally { clearTimeout(timer); }
        }""",
        int(timeout * 1000),
    )
    if res == "timeout":
        raise HarnessTimeout(f"Timed out after {timeout:.1f} s waiting for notebook:run-all-cells to finish")
    wait_for_kernel_idle(page, path, timeout=timeout)
    info = page.evaluate(_JS_CELL_ERRORS, path)
    if info["errs"] and raise_on_error:
        e = info["errs"][0]
        raise CellExecutionError(
            f"cell {e['cell']} raised {e['ename']}: {e['evalue']}\n{_strip_ansi(e['traceback'])}"
        )
    if info["unrun"] and raise_on_error:
        raise CellExecutionError(f"cells {info['unrun']} did not run")


# --------------------------------------------------------------------------
# Talking to the kernel directly
# --------------------------------------------------------------------------

_JS_KERNEL_EXECUTE = _with_find_panel(r"""
async ({path, code, timeoutMs}) => {
  const p = __gwFindPanel(path);
  if (!p) return {fatal: 'no notebook panel found for ' + path};
  const k = p.sessionContext.session && p.sessionContext.session.kernel;
  if (!k) return {fatal: 'the notebook has no kernel'};
  const out = {stdout: '', stderr: '', results: [], error: null, status: null, timeout: false};
  const future = k.requestExecute({code, silent: false, store_history: false, allow_stdin: false, stop_on_error: false});
  future.onIOPub = (msg) => {
    const t = msg.header.msg_type, c = msg.content;
    if (t === 'stream') { if (c.name === 'stdout') out.stdout += c.text; else out.stderr += c.text; }
    else if (t === 'execute_result') out.results.push(c.data['text/plain']);
    else if (t === 'error') out.error = {ename: c.ename, evalue: c.evalue, traceback: c.traceback.join('\n')};
  };
  let timer;
  const to = new Promise((res) => { timer = setTimeout(() => res(null), timeoutMs); });
  try {
    const reply = await Promise.race([future.done, to]);
    if (reply === null) { out.timeout = true; try { future.dispose(); } catch (e) {} }
    else {
      out.status = reply.content.status;
      if (out.status === 'error' && !out.error) out.error = {ename: reply.content.ename, evalue: reply.content.evalue, traceback: (reply.content.traceback || []).join('\n')};
    }
  } catch (e) { out.fatal = String(e); }
  finally { clearTimeout(timer); }
  return out;
}
""")


@dataclass
class KernelResult:
    """What :func:`kernel_execute` collected from the kernel."""

    stdout: str = ""
    stderr: str = ""
    results: list = field(default_factory=list)  #: text/plain of execute_result(s)


def kernel_execute(page, code: str, path: Optional[str] = None, timeout: float = 30.0) -> KernelResult:
    """Execute ``code`` in the notebook's kernel (through the page's own
    kernel connection, ``sessionContext.session.kernel.requestExecute``)
    without adding a cell, and return its stdout/stderr/results.

    Raises :class:`KernelExecutionError` if the code raised and
    :class:`HarnessTimeout` if no reply came within ``timeout``."""
    out = page.evaluate(_JS_KERNEL_EXECUTE, {"path": path, "code": code, "timeoutMs": int(timeout * 1000)})
    if out.get("fatal"):
        raise HarnessError(f"kernel_execute failed: {out['fatal']}")
    if out["timeout"]:
        raise HarnessTimeout(
            f"Timed out after {timeout:.1f} s waiting for the kernel to reply to: {code[:200]!r}; "
            f"stdout so far: {out['stdout'][-500:]!r}"
        )
    if out["error"]:
        e = out["error"]
        tb = _strip_ansi(e["traceback"])
        raise KernelExecutionError(
            f"kernel code raised {e['ename']}: {e['evalue']}\n{tb}", e["ename"], e["evalue"], tb
        )
    return KernelResult(out["stdout"], out["stderr"], out["results"])


def kernel_eval(page, expr: str, path: Optional[str] = None, timeout: float = 30.0) -> Any:
    """Evaluate a Python expression in the kernel and return its value,
    round-tripped through JSON (so it must be JSON-serialisable; use e.g.
    ``float(...)`` or ``.tolist()``)."""
    marker = "@@gw-" + uuid.uuid4().hex + "@@"
    code = f"import json as _gw_json\nprint({marker!r} + _gw_json.dumps({expr}))\ndel _gw_json"
    res = kernel_execute(page, code, path, timeout)
    for line in res.stdout.splitlines():
        if line.startswith(marker):
            return json.loads(line[len(marker):])
    raise HarnessError(f"kernel_eval({expr!r}) printed no result; stdout was {res.stdout!r}")


_MISSING = object()


def wait_for_kernel(
    page,
    expr: str,
    expected: Any = _MISSING,
    predicate: Optional[Callable[[Any], bool]] = None,
    path: Optional[str] = None,
    timeout: float = 20.0,
    interval: float = 0.25,
) -> Any:
    """Poll ``kernel_eval(expr)`` until it equals ``expected`` (floats are
    compared with 1e-9 relative tolerance) or ``predicate(value)`` is true.
    Returns the value. Use it to check that something done in the page
    reached Python, e.g. ``wait_for_kernel(page, "s.value", 25.0)``."""
    if predicate is None:
        if expected is _MISSING:
            raise TypeError("give expected or predicate")

        def predicate(v):
            if isinstance(v, (int, float)) and isinstance(expected, (int, float)):
                return abs(v - expected) <= 1e-9 * max(1.0, abs(expected))
            return v == expected

        what = f"kernel expression {expr} to equal {expected!r}"
    else:
        what = f"kernel expression {expr} to satisfy {getattr(predicate, '__name__', 'predicate')}"

    def check():
        v = kernel_eval(page, expr, path, timeout=min(timeout, 15.0))
        return bool(predicate(v)), v

    return poll(check, what, timeout, interval, page=page)


# --------------------------------------------------------------------------
# Frames of the jupyter-rfb view
# --------------------------------------------------------------------------

VIEW_SELECTOR = "div.renderview-wrapper img.renderview-view"

_JS_INSTALL_COUNTER = r"""
() => {
  if (window.__gwFrames) return false;
  const st = window.__gwFrames = {total: 0, last: performance.now()};
  const obs = new MutationObserver((muts) => {
    const now = performance.now();
    for (const m of muts) {
      const t = m.target;
      if (t.tagName !== 'IMG' || !t.classList.contains('renderview-view')) continue;
      if (t.getAttribute('src') === m.oldValue) continue;
      t.__gwCount = (t.__gwCount || 0) + 1;
      t.__gwLast = now;
      st.total += 1;
      st.last = now;
    }
  });
  obs.observe(document.documentElement, {subtree: true, attributes: true, attributeFilter: ['src'], attributeOldValue: true});
  st.observer = obs;
  return true;
}
"""

_JS_FRAME_INFO = r"""
(index) => {
  const st = window.__gwFrames;
  if (!st) return null;
  const now = performance.now();
  if (index === null) return {count: st.total, sinceLast: now - st.last, now, views: document.querySelectorAll('img.renderview-view').length};
  const img = document.querySelectorAll('img.renderview-view')[index];
  if (!img) return {count: 0, sinceLast: null, now, views: document.querySelectorAll('img.renderview-view').length, missing: true};
  return {count: img.__gwCount || 0, sinceLast: now - (img.__gwLast || st.last), now, views: document.querySelectorAll('img.renderview-view').length};
}
"""


def install_frame_counter(page) -> bool:
    """Install (idempotently) a MutationObserver that counts ``src``
    changes of every ``img.renderview-view`` in the page, including views
    created later. :func:`open_notebook` calls this; call it again after a
    page reload. Returns True if it was newly installed."""
    return page.evaluate(_JS_INSTALL_COUNTER)


def _frame_info(page, index: Optional[int]) -> dict:
    info = page.evaluate(_JS_FRAME_INFO, index)
    if info is None:
        raise HarnessError("frame counter not installed; call install_frame_counter(page) first")
    return info


def frame_count(page, index: Optional[int] = None) -> int:
    """Frames seen since the counter was installed: over all views, or for
    the ``index``-th ``img.renderview-view`` in document order."""
    return _frame_info(page, index)["count"]


def frame_counts(page) -> list:
    """Frames seen since the counter was installed, per ``img.renderview-view`` in document
    order, all read at one instant (one evaluation: no frame arrives between two views' reads)."""
    counts = page.evaluate("() => window.__gwFrames ? [...document.querySelectorAll('img.renderview-view')]"
                           ".map((img) => img.__gwCount || 0) : null")
    if counts is None:
        raise HarnessError("frame counter not installed; call install_frame_counter(page) first")
    return counts


def wait_for_view(page, index: int = 0, timeout: float = 60.0):
    """Wait until the ``index``-th jupyter-rfb view exists, is visible and
    shows a decoded image; returns its locator.

    The view is scrolled into the viewport as soon as it exists: jupyter-rfb
    draws only for views the browser reports visible (IntersectionObserver),
    so a view left below the fold (e.g. after running a long notebook, which
    scrolls to its end) would never get its first frame."""
    loc = view_locator(page, index)

    def check():
        st = page.evaluate(
            """(i) => { const img = document.querySelectorAll('img.renderview-view')[i];
                 if (!img) return {exists: false};
                 let r = img.getBoundingClientRect();
                 if (r.bottom <= 0 || r.top >= window.innerHeight) {
                   img.scrollIntoView({block: 'center'});
                   r = img.getBoundingClientRect();
                 }
                 return {exists: true, w: r.width, h: r.height, natural: [img.naturalWidth, img.naturalHeight],
                         complete: img.complete, blob: (img.getAttribute('src') || '').startsWith('blob:')}; }""",
            index,
        )
        ok = st["exists"] and st["w"] > 0 and st["h"] > 0 and st["complete"] and st["natural"][0] > 1
        return bool(ok), st

    poll(check, f"jupyter-rfb view #{index} to show an image", timeout, 0.2, page=page)
    loc.scroll_into_view_if_needed()
    return loc


def wait_for_frames(page, n: int, timeout: float = 30.0, index: Optional[int] = None) -> int:
    """Wait until ``n`` *new* frames (counted from this call) have arrived,
    in any view or in view ``index``. Returns the frame count reached."""
    start = frame_count(page, index)

    def check():
        c = frame_count(page, index)
        return c - start >= n, c

    return poll(
        check,
        f"{n} new frames in {'any jupyter-rfb view' if index is None else f'view #{index}'} (had {start})",
        timeout,
        0.1,
        page=page,
    )


def frames_per_second(page, seconds: float = 3.0, index: Optional[int] = None) -> float:
    """Measure frames/s reaching the page over a ``seconds``-long window
    (uses the page's clock)."""
    a = _frame_info(page, index)
    page.wait_for_timeout(seconds * 1000)
    b = _frame_info(page, index)
    return (b["count"] - a["count"]) / ((b["now"] - a["now"]) / 1000.0)


def wait_until_quiet(page, quiet_s: float = 0.8, timeout: float = 20.0, index: Optional[int] = None) -> int:
    """Wait until no new frame has arrived for ``quiet_s`` seconds (all
    views, or view ``index``). jupyter-rfb sends a lossless PNG ~0.3 s
    after the last JPEG, so use quiet_s > 0.5 before exact pixel checks.
    Returns the frame count. Only succeeds once the animation has stopped
    (e.g. update mode "ondemand")."""

    def check():
        info = _frame_info(page, index)
        return info["sinceLast"] is not None and info["sinceLast"] >= quiet_s * 1000, info

    info = poll(check, f"the view(s) to receive no frame for {quiet_s} s", timeout, 0.1, page=page)
    return info["count"]


def view_locator(page, index: int = 0):
    """Locator of the ``index``-th jupyter-rfb ``img.renderview-view``."""
    return page.locator(VIEW_SELECTOR).nth(index)


_JS_VIEW_PIXELS = r"""
async (index) => {
  const img = document.querySelectorAll('img.renderview-view')[index];
  if (!img) return {error: 'no img.renderview-view #' + index + ' in the page'};
  const src = img.getAttribute('src');
  if (!img.complete || !img.naturalWidth) { try { await img.decode(); } catch (e) {} }
  if (!img.naturalWidth) return {error: 'view image not decoded (src ' + (src || '').slice(0, 40) + ')'};
  const c = document.createElement('canvas');
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const ctx = c.getContext('2d', {willReadFrequently: true});
  ctx.drawImage(img, 0, 0);
  const d = ctx.getImageData(0, 0, c.width, c.height).data;
  let s = '';
  const CH = 0x8000;
  for (let i = 0; i < d.length; i += CH) s += String.fromCharCode.apply(null, d.subarray(i, i + CH));
  return {w: c.width, h: c.height, b64: btoa(s), src};
}
"""


def view_pixels(page, index: int = 0):
    """The image currently shown by view ``index`` at its natural (frame)
    resolution, as a numpy array (h, w, 4) uint8 RGBA, decoded in the page
    through a canvas. JPEG while animating; call :func:`wait_until_quiet`
    first to get the final lossless PNG."""
    import numpy as np

    res = page.evaluate(_JS_VIEW_PIXELS, index)
    if res.get("error"):
        raise HarnessError(res["error"])
    arr = np.frombuffer(base64.b64decode(res["b64"]), dtype=np.uint8)
    return arr.reshape(res["h"], res["w"], 4).copy()


def view_screenshot(page, index: int = 0, path=None):
    """Screenshot of the view element as displayed (CSS size) as numpy
    (h, w, 4) uint8; also written to ``path`` if given."""
    import io

    import numpy as np
    from PIL import Image

    png = view_locator(page, index).screenshot(path=str(path) if path else None)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).copy()


# --------------------------------------------------------------------------
# Input
# --------------------------------------------------------------------------


def drag(
    page,
    locator,
    dx: float,
    dy: float,
    *,
    start: Optional[tuple] = None,
    steps: int = 20,
    step_ms: float = 40,
    hold_ms: float = 150,
    button: str = "left",
) -> None:
    """Drag with the mouse over ``locator`` by (dx, dy) CSS pixels, at human
    speed (``steps`` moves ``step_ms`` apart, ``hold_ms`` pauses after press
    and before release) so jupyter-rfb's 20 ms move throttle keeps the
    events. ``start`` is an (x, y) offset within the element; default its
    centre. The fixed pauses here are pacing, not waits for a condition."""
    locator.scroll_into_view_if_needed()
    box = locator.bounding_box()
    if box is None:
        raise HarnessError("drag: element is not visible")
    sx, sy = start if start is not None else (box["width"] / 2, box["height"] / 2)
    x0, y0 = box["x"] + sx, box["y"] + sy
    m = page.mouse
    m.move(x0, y0)
    page.wait_for_timeout(step_ms)
    m.down(button=button)
    page.wait_for_timeout(hold_ms)
    for i in range(1, steps + 1):
        m.move(x0 + dx * i / steps, y0 + dy * i / steps)
        page.wait_for_timeout(step_ms)
    page.wait_for_timeout(hold_ms)
    m.up(button=button)


def _exact(text: str):
    return re.compile(r"^\s*" + re.escape(text) + r"\s*$")


def _one(locator, what: str, candidates_js: Optional[str] = None, page=None, timeout: float = 10.0):
    """Wait until ``locator`` matches exactly one element; clear error otherwise."""

    def check():
        n = locator.count()
        return n == 1, n

    try:
        poll(check, what, timeout, 0.2, page=page)
    except HarnessTimeout as exc:
        extra = ""
        if candidates_js and page is not None:
            extra = f"; present on the page: {page.evaluate(candidates_js)!r}"
        raise HarnessTimeout(f"{exc}{extra}") from None
    return locator


_JS_SLIDER_LABELS = """() => Array.from(document.querySelectorAll('.widget-slider')).map(
  (s) => { const l = s.querySelector('.widget-label:not(.widget-readout)'); return l ? l.textContent : ''; })"""


def panel_label(trait: str) -> str:
    """The label the widget's panel shows for a GrassParams (or widget) trait, e.g.
    ``panel_label("gravity") == "gravity (m/s²)"`` (grasswidget.notebook.panel.control_label)."""
    import grasswidget as gw
    from grasswidget.notebook.panel import control_label

    traits = {**gw.GrassWidget.class_traits(), **gw.GrassParams.class_traits()}
    return control_label(trait, traits.get(trait))


def _slider(page, description: str, timeout: float):
    loc = page.locator(".widget-slider").filter(
        has=page.locator(".widget-label:not(.widget-readout)", has_text=_exact(description))
    )
    return _one(loc, f"exactly one slider labelled {description!r}", _JS_SLIDER_LABELS, page, timeout)


def slider_readout(page, description: str, timeout: float = 10.0) -> str:
    """Text of the readout of the slider labelled ``description``."""
    return _slider(page, description, timeout).locator(".widget-readout").inner_text().strip()


def set_slider(page, description: str, value: float, timeout: float = 10.0, check: bool = True) -> str:
    """Set an ipywidgets (Int/Float)Slider, found by its description label,
    by typing ``value`` into its editable readout and pressing Enter, like a
    user. With ``check`` waits until the readout shows the value (within
    0.5 % of the slider's visible precision). Returns the readout text.
    The kernel side is *not* checked: use :func:`wait_for_kernel`."""
    slider = _slider(page, description, timeout)
    readout = slider.locator(".widget-readout")
    if readout.get_attribute("contenteditable") != "true":
        raise HarnessError(f"slider {description!r} has no editable readout (readout=False or disabled?)")
    readout.scroll_into_view_if_needed()
    readout.click()
    readout.fill(str(value))
    readout.press("Enter")
    if not check:
        return readout.inner_text().strip()

    def ok():
        text = readout.inner_text().strip()
        try:
            shown = float(text.replace("\u2212", "-"))
        except ValueError:
            return False, text
        decimals = len(text.split(".")[1]) if "." in text else 0
        return abs(shown - float(value)) <= 0.5 * 10 ** (-decimals) + 1e-9, text

    return poll(ok, f"slider {description!r} readout to show {value}", timeout, 0.1, page=page)


def click_button(page, text: str, timeout: float = 10.0) -> None:
    """Click the ipywidgets Button (or ToggleButton) whose text is ``text``."""
    loc = page.locator("button.jupyter-button").filter(has_text=_exact(text))
    js = "() => Array.from(document.querySelectorAll('button.jupyter-button')).map((b) => b.textContent)"
    _one(loc, f"exactly one widget button {text!r}", js, page, timeout).click()


def toggle_checkbox(page, description: str, value: Optional[bool] = None, timeout: float = 10.0) -> bool:
    """Click the ipywidgets Checkbox labelled ``description`` (or, with
    ``value``, set it to that state). Returns the new checked state."""
    box = page.locator(".widget-checkbox").filter(
        has=page.locator(".widget-label-basic span", has_text=_exact(description))
    )
    js = ("() => Array.from(document.querySelectorAll('.widget-checkbox .widget-label-basic span'))"
          ".map((s) => s.textContent)")
    inp = _one(box, f"exactly one checkbox labelled {description!r}", js, page, timeout).locator(
        "input[type=checkbox]"
    )
    if value is None:
        before = inp.is_checked()
        inp.click()
        poll(lambda: (inp.is_checked() != before, inp.is_checked()), f"checkbox {description!r} to toggle",
             timeout, 0.1, page=page)
    else:
        inp.set_checked(bool(value))
    return inp.is_checked()


def choose_option(page, description: str, option: str, timeout: float = 10.0) -> str:
    """Choose ``option`` (its text) in the ipywidgets Dropdown labelled ``description``,
    e.g. a panel's auto / on / off switch. Returns the chosen option's text."""
    box = page.locator(".widget-dropdown").filter(
        has=page.locator("label.widget-label", has_text=_exact(description))
    )
    js = ("() => Array.from(document.querySelectorAll('.widget-dropdown label.widget-label'))"
          ".map((s) => s.textContent)")
    select = _one(box, f"exactly one dropdown labelled {description!r}", js, page, timeout).locator("select")
    select.select_option(label=option)
    poll(lambda: (select.evaluate("(s) => s.options[s.selectedIndex].text") == option, None),
         f"dropdown {description!r} to show {option!r}", timeout, 0.1, page=page)
    return option


# --------------------------------------------------------------------------
# Reading outputs
# --------------------------------------------------------------------------

_JS_OUTPUT_TEXT = _with_find_panel(r"""
({path, index}) => {
  const p = __gwFindPanel(path);
  if (!p) return null;
  const cells = p.content.widgets.filter((c) => c.model.type === 'code');
  const pick = index === null ? cells : [cells[index < 0 ? cells.length + index : index]];
  return pick.filter(Boolean).map((c) => c.outputArea ? c.outputArea.node.innerText : '').join('\n');
}
""")


def cell_output_text(page, cell_index: Optional[int] = None, path: Optional[str] = None) -> str:
    """Visible text of the outputs of the ``cell_index``-th *code* cell
    (negative counts from the end; None: all code cells joined). This
    includes the text of widgets such as Label, HTML and button captions."""
    res = page.evaluate(_JS_OUTPUT_TEXT, {"path": path, "index": cell_index})
    if res is None:
        raise HarnessError("no notebook panel found")
    return res


def wait_for_output_text(
    page, text: str, cell_index: Optional[int] = None, path: Optional[str] = None, timeout: float = 20.0
) -> str:
    """Wait until ``text`` (a str, or a compiled regex) appears in the
    outputs (see :func:`cell_output_text`). Returns the full output text."""
    if isinstance(text, re.Pattern):
        match = lambda s: bool(text.search(s))  # noqa: E731
    else:
        match = lambda s: text in s  # noqa: E731

    def check():
        s = cell_output_text(page, cell_index, path)
        return match(s), s[-500:]

    poll(check, f"output text {text!r}", timeout, 0.2, page=page)
    return cell_output_text(page, cell_index, path)


def save_debug_artifacts(page, out_dir, name: str = "failure", browser: Optional[Browser] = None,
                         server: Optional[JupyterLabServer] = None) -> Path:
    """Write a full-page screenshot, the browser console and the server log
    into ``out_dir`` (for post-mortems); returns the directory."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    try:
        page.screenshot(path=str(out / f"{name}.png"), full_page=True, timeout=10_000)
    except Exception as exc:  # the page may be gone
        (out / f"{name}.screenshot-error.txt").write_text(repr(exc))
    if browser is not None:
        (out / f"{name}.console.txt").write_text("\n".join(browser.console))
    if server is not None:
        (out / f"{name}.server.log").write_text(server.log_text())
    return out
