"""The server processes a browser test talks to: JupyterLab, Jupyter Notebook 7 and Voila
(:class:`JupyterLabServer`), ``marimo run``/``edit`` (:class:`MarimoServer`) and plain files
(:class:`StaticServer`, a thread of this process).

Processes are started and stopped by PID: a server and the kernels it started (found by walking
``/proc`` from the server's PID). Each Jupyter server gets fresh private config, runtime, data,
IPython and XDG runtime directories, so nothing from ``~/.jupyter`` or a previous run leaks in.
"""

from __future__ import annotations

import json
import os
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
from pathlib import Path
from typing import Any, Iterable, Optional

from .polling import HarnessError, HarnessTimeout, poll


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
        # Notebook 7 and JupyterLab: the same Jupyter server, each app's own flags last
        own = (["--JupyterNotebookApp.expose_app_in_browser=True"] if self.app == "notebook" else
               ["--LabApp.expose_app_in_browser=True", "--LabApp.news_url=None",
                "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate"])
        return [
            self.python, "-m", "notebook" if self.app == "notebook" else "jupyterlab",
            f"--ServerApp.root_dir={self.root_dir}",
            "--ServerApp.ip=127.0.0.1",
            f"--ServerApp.port={self.port}",
            "--ServerApp.port_retries=0",
            f"--IdentityProvider.token={self.token}",
            "--ServerApp.open_browser=False",
            "--ServerApp.allow_root=True",
            "--ServerApp.terminals_enabled=False",
            *own,
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
