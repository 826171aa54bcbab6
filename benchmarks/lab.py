"""A small driver of JupyterLab and headless Chromium for the benchmarks that measure a page.

The test suite has its own, larger harness (tests/e2e/); the benchmarks import nothing from tests/, so this
module holds what they need: a JupyterLab server and a static file server on private ports and state folders,
Chromium through Playwright (optionally with WebGPU on SwiftShader), opening a notebook and running its cells,
code run in the notebook's kernel, the kernel engine's frames counted in the page, and a user's input (a drag,
a slider, a button, a checkbox).

Rules: every wait polls a condition until it holds or a timeout passes, then raises :class:`DriverTimeout`
with what it last saw (the fixed pauses are a drag's pacing and a frames/s window); every process started here
is stopped by its own id, kernels included.
"""

from __future__ import annotations

import http.server
import json
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
import uuid
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

#: Chromium (Debian's); GW_CHROMIUM overrides it.
CHROMIUM = os.environ.get("GW_CHROMIUM", "/usr/bin/chromium")
#: Flags for headless Chromium on a closed network with timers at full rate in a never-focused window.
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--no-first-run", "--disable-quic", "--disable-sync",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
                  "--disable-backgrounding-occluded-windows")
#: Added for a WebGPU adapter on the CPU (SwiftShader); without them Chromium also gets --disable-gpu.
WEBGPU_FLAGS = ("--enable-unsafe-webgpu", "--enable-features=Vulkan", "--use-vulkan=swiftshader",
                "--use-webgpu-adapter=swiftshader", "--use-angle=swiftshader")
#: The jupyter-rfb view of the kernel engine: each frame is a new ``src`` of this image.
RFB_VIEW = "img.renderview-view"
#: The browser engine's canvas.
ENGINE_CANVAS = "canvas.grasswidget-canvas"
#: JS: the newest open browser engine in the page (null if none; engine.js keeps them in a Map by key).
LAST_ENGINE = ("(() => { const es = [...(globalThis.__grasswidgetEngines || new Map()).values()]"
               ".filter((e) => !e.closed); return es[es.length - 1] || null; })()")


class DriverError(RuntimeError):
    """Something the driver asked of the server, browser or kernel failed."""


class DriverTimeout(DriverError, TimeoutError):
    """A condition did not hold within its timeout."""


def poll(check: Callable[[], Any], what: str, timeout: float, interval: float = 0.1, page=None) -> Any:
    """Call ``check()`` until it holds and return what it saw: ``check`` returns ``(ok, value)`` or one value
    taken as its truth. After ``timeout`` seconds raise :class:`DriverTimeout` naming ``what`` and the last value
    seen. With ``page``, the pauses run through it (its events keep flowing)."""
    deadline = time.monotonic() + timeout
    while True:
        got = check()
        ok, last = got if isinstance(got, tuple) and len(got) == 2 else (bool(got), got)
        if ok:
            return last
        if time.monotonic() >= deadline:
            raise DriverTimeout(f"waited {timeout:.0f} s for {what}; last seen: {str(last)[:500]}")
        if page is not None:
            page.wait_for_timeout(interval * 1000)
        else:
            time.sleep(interval)


def write_notebook(path, cells: Sequence[str]) -> Path:
    """Write a notebook (nbformat 4) of code ``cells`` with the python3 kernel."""
    nb = {"cells": [{"cell_type": "code", "execution_count": None, "id": uuid.uuid4().hex[:8], "metadata": {},
                     "outputs": [], "source": src} for src in cells],
          "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"}},
          "nbformat": 4, "nbformat_minor": 5}
    path = Path(path)
    path.write_text(json.dumps(nb, indent=1))
    return path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _children(pid: int) -> list:
    """Every descendant process id of ``pid`` (from /proc)."""
    parent_of = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    parent_of[int(entry)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, parent in parent_of.items() if parent == p]
        found += kids
        todo += kids
    return found


def _stop(pids: Sequence[int], timeout: float = 10.0) -> None:
    for pid in pids:
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
    deadline = time.monotonic() + timeout
    for pid in pids:
        while time.monotonic() < deadline and os.path.exists(f"/proc/{pid}") and _state(pid) != "Z":
            time.sleep(0.05)
        if os.path.exists(f"/proc/{pid}") and _state(pid) != "Z":
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


def _state(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return "Z"


class JupyterLabServer:
    """``python -m jupyterlab`` serving ``root`` on a free local port, with private config, data and runtime
    folders (nothing of ~/.jupyter reaches it), the app exposed to the page as ``window.jupyterapp``, news,
    update checks and announcements off. ``env``: extra environment variables for the server and its kernels."""

    def __init__(self, root, env: Optional[dict] = None, startup_timeout: float = 90.0):
        self.root = Path(root)
        self.port = _free_port()
        self.token = secrets.token_hex(16)
        self.extra_env = dict(env or {})
        self.startup_timeout = startup_timeout
        self.proc: Optional[subprocess.Popen] = None
        self.state: Optional[Path] = None

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    def url_for(self, relpath: str) -> str:
        """The Lab URL that opens notebook ``relpath`` (relative to ``root``) with a fresh workspace."""
        return f"{self.base_url}lab/tree/{relpath}?reset&token={self.token}"

    def api(self, path: str, method: str = "GET") -> Any:
        req = urllib.request.Request(f"{self.base_url}api/{path}", method=method,
                                     headers={"Authorization": f"token {self.token}"})
        with urllib.request.urlopen(req, timeout=10) as resp:
            body = resp.read()
        return json.loads(body) if body else None

    def start(self) -> "JupyterLabServer":
        self.state = Path(tempfile.mkdtemp(prefix="gw-bench-lab-"))
        for sub in ("config", "data", "runtime", "ipython"):
            (self.state / sub).mkdir()
        labconfig = self.state / "config" / "labconfig"
        labconfig.mkdir()
        (labconfig / "page_config.json").write_text(json.dumps(
            {"disabledExtensions": {"@jupyterlab/apputils-extension:announcements": True}}))
        settings = self.state / "config" / "lab" / "user-settings" / "@jupyterlab"
        for folder, name, value in (
                ("notebook-extension", "tracker", {"windowingMode": "none"}),  # every cell in the DOM
                ("apputils-extension", "notification", {"fetchNews": "false", "checkForUpdates": False,
                                                        "doNotDisturbMode": True})):  # no toast over a view
            (settings / folder).mkdir(parents=True, exist_ok=True)
            (settings / folder / f"{name}.jupyterlab-settings").write_text(json.dumps(value))
        env = dict(os.environ, JUPYTER_CONFIG_DIR=str(self.state / "config"), JUPYTER_DATA_DIR=str(self.state / "data"),
                   JUPYTER_RUNTIME_DIR=str(self.state / "runtime"), IPYTHONDIR=str(self.state / "ipython"),
                   JUPYTER_PLATFORM_DIRS="1", PYTHONUNBUFFERED="1", **self.extra_env)
        env.pop("JUPYTER_TOKEN", None)
        self._log = open(self.state / "server.log", "wb")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "jupyterlab", f"--ServerApp.root_dir={self.root}", "--ServerApp.ip=127.0.0.1",
             f"--ServerApp.port={self.port}", "--ServerApp.port_retries=0", f"--IdentityProvider.token={self.token}",
             "--ServerApp.open_browser=False", "--ServerApp.allow_root=True", "--ServerApp.terminals_enabled=False",
             "--LabApp.expose_app_in_browser=True", "--LabApp.news_url=None",
             "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate"],
            env=env, stdout=self._log, stderr=subprocess.STDOUT, cwd=self.root)

        def up():
            if self.proc.poll() is not None:
                raise DriverError(f"JupyterLab exited ({self.proc.returncode}):\n{self.log_text(3000)}")
            try:
                self.api("status")
                return True, "answering"
            except (urllib.error.URLError, OSError) as exc:
                return False, repr(exc)

        try:
            poll(up, "JupyterLab to answer /api/status", self.startup_timeout, 0.2)
        except BaseException:
            self.stop()
            raise
        return self

    def log_text(self, tail: int = 4000) -> str:
        """The end of the server's log."""
        try:
            return (self.state / "server.log").read_bytes()[-tail:].decode("utf-8", "replace")
        except (OSError, TypeError):
            return ""

    def shutdown_kernels(self) -> int:
        """Shut every kernel of the server down (REST); returns how many there were."""
        kernels = self.api("kernels")
        for k in kernels:
            try:
                self.api(f"kernels/{k['id']}", method="DELETE")
            except urllib.error.URLError:
                pass
        return len(kernels)

    def stop(self) -> None:
        if self.proc is not None:
            _stop([*_children(self.proc.pid), self.proc.pid])
            self.proc.wait(timeout=10)
            self.proc = None
        if getattr(self, "_log", None):
            self._log.close()
        if self.state is not None:
            shutil.rmtree(self.state, ignore_errors=True)
            self.state = None

    def __enter__(self) -> "JupyterLabServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


class StaticServer:
    """A static file server of ``root`` on a free local port, in a thread of this process."""

    def __init__(self, root):
        self.root = Path(root)
        self.httpd = None

    def start(self) -> "StaticServer":
        root = str(self.root)

        class Quiet(http.server.SimpleHTTPRequestHandler):
            def __init__(self, *a, **k):
                super().__init__(*a, directory=root, **k)

            def log_message(self, *a):  # no line per request
                pass

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()
        return self

    def url_for(self, relpath: str) -> str:
        return f"http://127.0.0.1:{self.httpd.server_address[1]}/{relpath}"

    def stop(self) -> None:
        if self.httpd is not None:
            self.httpd.shutdown()
            self.httpd.server_close()
            self.httpd = None

    def __enter__(self) -> "StaticServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


class Browser:
    """Headless Chromium through Playwright with a fresh profile; ``.page`` is open, ``.context`` its context.
    ``webgpu``: with a WebGPU adapter on SwiftShader (the browser engine's benchmarks)."""

    def __init__(self, webgpu: bool = False, viewport: tuple = (1280, 1000), timeout: float = 30.0):
        self.webgpu = webgpu
        self.viewport = viewport
        self.timeout = timeout
        self.playwright = self.context = self.page = None
        self.profile: Optional[str] = None

    def start(self) -> "Browser":
        if not os.path.exists(CHROMIUM):
            raise DriverError(f"no Chromium at {CHROMIUM} (apt-get install chromium, or set GW_CHROMIUM)")
        from playwright.sync_api import sync_playwright

        flags = [*CHROMIUM_FLAGS, *WEBGPU_FLAGS] if self.webgpu else [*CHROMIUM_FLAGS, "--disable-gpu"]
        self.profile = tempfile.mkdtemp(prefix="gw-bench-chromium-")
        self.playwright = sync_playwright().start()
        try:
            self.context = self.playwright.chromium.launch_persistent_context(
                self.profile, executable_path=CHROMIUM, headless=True, args=flags,
                viewport={"width": self.viewport[0], "height": self.viewport[1]}, timeout=60_000)
            self.context.set_default_timeout(self.timeout * 1000)
            self.page = self.context.pages[0] if self.context.pages else self.context.new_page()
            # Lab asks "leave the page?" (beforeunload) when the page navigates away: leave; other dialogs: no
            self.context.on("page", self._answer_dialogs)
            self._answer_dialogs(self.page)
        except BaseException:
            self.stop()
            raise
        return self

    @staticmethod
    def _answer_dialogs(page) -> None:
        page.on("dialog", lambda d: d.accept() if d.type == "beforeunload" else d.dismiss())

    @property
    def version(self) -> str:
        return self.context.browser.version if self.context and self.context.browser else "chromium"

    def stop(self) -> None:
        if self.context is not None:
            self.context.close()
            self.context = None
        if self.playwright is not None:
            self.playwright.stop()
            self.playwright = None
        if self.profile:
            shutil.rmtree(self.profile, ignore_errors=True)
            self.profile = None

    def __enter__(self) -> "Browser":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


# ------------------------------------------------------------------ the notebook and its kernel

#: JS: the open notebook panel's state (its kernel's status, cells running or queued).
_NOTEBOOK = r"""() => {
  const app = window.jupyterapp;
  if (!app) return {ok: false, why: 'no window.jupyterapp yet'};
  const w = app.shell.currentWidget;
  if (!w || !w.sessionContext || !w.content) return {ok: false, why: 'no notebook is current'};
  const k = w.sessionContext.session && w.sessionContext.session.kernel;
  if (!w.context.isReady || !k) return {ok: false, why: 'no kernel yet'};
  let busy = 0;
  for (const c of w.content.widgets) {
    if (c.model.type === 'code' && (c.model.executionState === 'running'
        || (c.promptNode && c.promptNode.textContent.includes('*')))) busy++;
  }
  return {ok: true, status: k.status, connection: k.connectionStatus, busy};
}"""

#: JS: the errors in the current notebook's outputs.
_CELL_ERRORS = r"""() => {
  const w = window.jupyterapp.shell.currentWidget; const errs = [];
  w.content.widgets.forEach((c, i) => { if (c.model.type !== 'code') return;
    for (const o of c.model.outputs.toJSON()) if (o.output_type === 'error')
      errs.push({cell: i, ename: o.ename, evalue: o.evalue, traceback: (o.traceback || []).join('\n')}); });
  return errs;
}"""

#: JS: run ``code`` in the current notebook's kernel; collect stdout, stderr and an error, or time out.
_EXECUTE = r"""async ({code, ms}) => {
  const w = window.jupyterapp.shell.currentWidget;
  const k = w && w.sessionContext && w.sessionContext.session && w.sessionContext.session.kernel;
  if (!k) return {fatal: 'the current notebook has no kernel'};
  const out = {stdout: '', stderr: '', error: null, timeout: false};
  const f = k.requestExecute({code, silent: false, store_history: false, allow_stdin: false, stop_on_error: false});
  f.onIOPub = (m) => { const c = m.content;
    if (m.header.msg_type === 'stream') { if (c.name === 'stdout') out.stdout += c.text; else out.stderr += c.text; }
    else if (m.header.msg_type === 'error') out.error = c.ename + ': ' + c.evalue + '\n' + c.traceback.join('\n'); };
  let timer; const late = new Promise((r) => { timer = setTimeout(() => r(null), ms); });
  const reply = await Promise.race([f.done, late]); clearTimeout(timer);
  if (reply === null) { out.timeout = true; f.dispose(); }
  return out;
}"""

_ANSI = re.compile(r"\x1b\[[0-9;]*m")


def open_notebook(page, server: JupyterLabServer, relpath: str, timeout: float = 120.0) -> None:
    """Load Lab with notebook ``relpath`` and wait until its kernel is connected and idle; then count the kernel
    engine's frames (:func:`install_frame_counter`)."""
    page.goto(server.url_for(relpath), wait_until="domcontentloaded", timeout=timeout * 1000)

    def ready():
        st = page.evaluate(_NOTEBOOK)
        return bool(st.get("ok") and st["connection"] == "connected" and st["status"] == "idle"), st

    poll(ready, f"notebook {relpath} to open with an idle kernel", timeout, 0.25)
    install_frame_counter(page)


def run_all_cells(page, timeout: float = 180.0) -> None:
    """Run every cell of the current notebook and wait until none runs or waits; a cell's error raises
    DriverError with its traceback."""
    ran = page.evaluate("""async (ms) => { let timer;
      const late = new Promise((r) => { timer = setTimeout(() => r('late'), ms); });
      const r = await Promise.race([window.jupyterapp.commands.execute('notebook:run-all-cells'), late]);
      clearTimeout(timer); return r === 'late' ? 'late' : 'ran'; }""", int(timeout * 1000))
    if ran == "late":
        raise DriverTimeout(f"notebook:run-all-cells did not finish within {timeout:.0f} s")

    def done():
        st = page.evaluate(_NOTEBOOK)
        return bool(st.get("ok") and st["status"] == "idle" and st["busy"] == 0), st

    poll(done, "the cells to finish", timeout, 0.2)
    errors = page.evaluate(_CELL_ERRORS)
    if errors:
        e = errors[0]
        raise DriverError(f"cell {e['cell']} raised {e['ename']}: {e['evalue']}\n{_ANSI.sub('', e['traceback'])}")


def kernel_execute(page, code: str, timeout: float = 30.0) -> str:
    """Run ``code`` in the current notebook's kernel (no cell added); return its stdout. An exception in it
    raises DriverError; no reply within ``timeout`` raises DriverTimeout."""
    out = page.evaluate(_EXECUTE, {"code": code, "ms": int(timeout * 1000)})
    if out.get("fatal"):
        raise DriverError(out["fatal"])
    if out["timeout"]:
        raise DriverTimeout(f"the kernel did not answer within {timeout:.0f} s: {code[:200]!r}")
    if out["error"]:
        raise DriverError(f"kernel code {code[:200]!r} raised {_ANSI.sub('', out['error'])}")
    return out["stdout"]


def kernel_eval(page, expr: str, timeout: float = 30.0) -> Any:
    """The value of Python expression ``expr`` in the kernel, through JSON (so it must be JSON-able)."""
    mark = f"@@{uuid.uuid4().hex}@@"
    text = kernel_execute(page, f"import json as _j\nprint({mark!r} + _j.dumps({expr}))\ndel _j", timeout)
    for line in text.splitlines():
        if line.startswith(mark):
            return json.loads(line[len(mark):])
    raise DriverError(f"kernel_eval({expr!r}) printed nothing; stdout {text[-300:]!r}")


def wait_for_kernel(page, expr: str, expected: Any, timeout: float = 30.0) -> Any:
    """Poll ``expr`` in the kernel until it equals ``expected`` (numbers within 1e-9 relative)."""

    def same(v):
        if isinstance(v, (int, float)) and isinstance(expected, (int, float)) and not isinstance(v, bool):
            return abs(v - expected) <= 1e-9 * max(1.0, abs(expected))
        return v == expected

    return poll(lambda: (lambda v: (same(v), v))(kernel_eval(page, expr)), f"{expr} == {expected!r}", timeout, 0.25)


# ------------------------------------------------------------------ frames and input

#: JS: count every new ``src`` of a jupyter-rfb view image in the page (views made later too), once.
_COUNTER = r"""() => {
  if (window.__gwBenchFrames) return false;
  const st = window.__gwBenchFrames = {total: 0};
  new MutationObserver((ms) => { for (const m of ms) {
    const t = m.target;
    if (t.tagName === 'IMG' && t.classList.contains('renderview-view') && t.getAttribute('src') !== m.oldValue) {
      t.__gwBenchCount = (t.__gwBenchCount || 0) + 1; st.total++; } } })
    .observe(document.documentElement, {subtree: true, attributes: true, attributeFilter: ['src'],
                                        attributeOldValue: true});
  return true;
}"""


def install_frame_counter(page) -> bool:
    """Count the kernel engine's frames shown in the page from now (after a reload: call it again)."""
    return page.evaluate(_COUNTER)


def frame_count(page, index: Optional[int] = None) -> int:
    """Frames shown so far: by every kernel-engine view, or by view ``index``."""
    return int(page.evaluate("""(i) => { const st = window.__gwBenchFrames; if (!st) return 0;
      if (i === null) return st.total; const img = document.querySelectorAll('img.renderview-view')[i];
      return img ? (img.__gwBenchCount || 0) : 0; }""", index))


def wait_for_frames(page, n: int, timeout: float = 60.0, index: Optional[int] = None) -> int:
    """Wait until at least ``n`` frames were shown (see :func:`frame_count`)."""
    return poll(lambda: (lambda c: (c >= n, c))(frame_count(page, index)), f"{n} frames in the page", timeout, 0.1)


def frames_per_second(page, seconds: float = 3.0, index: Optional[int] = None) -> float:
    """Frames shown per second over a window of ``seconds`` (the page's own clock)."""
    a, t0 = frame_count(page, index), page.evaluate("() => performance.now()")
    page.wait_for_timeout(seconds * 1000)
    b, t1 = frame_count(page, index), page.evaluate("() => performance.now()")
    return (b - a) / ((t1 - t0) / 1000.0)


def engine_state(page, expr: str = "e && {timing: e.timing, frames: e.frames}") -> Any:
    """``expr`` of the browser engine created last in the page (``e``; null when there is none)."""
    return page.evaluate(f"() => {{ const e = {LAST_ENGINE}; return {expr}; }}")


def view_locator(page, index: int = 0):
    """The ``index``-th kernel-engine view (a jupyter-rfb image)."""
    return page.locator(RFB_VIEW).nth(index)


def drag(page, locator, dx: float, dy: float, steps: int = 20, step_ms: float = 40, hold_ms: float = 150) -> None:
    """Drag the mouse from the middle of ``locator`` by (dx, dy) CSS px at a person's pace (jupyter-rfb keeps one
    move per 20 ms)."""
    locator.scroll_into_view_if_needed()
    box = locator.bounding_box()
    if box is None:
        raise DriverError("drag: the element is not shown")
    x0, y0 = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x0, y0)
    page.mouse.down()
    page.wait_for_timeout(hold_ms)
    for i in range(1, steps + 1):
        page.mouse.move(x0 + dx * i / steps, y0 + dy * i / steps)
        page.wait_for_timeout(step_ms)
    page.wait_for_timeout(hold_ms)
    page.mouse.up()


def panel_label(trait: str) -> str:
    """The label of ``trait``'s control in the widget's panel, as the package writes it."""
    import grasswidget as gw
    from grasswidget.notebook.panel import control_label

    traits = {**gw.GrassWidget.class_traits(), **gw.GrassParams.class_traits()}
    return control_label(trait, traits.get(trait))


def _only(locator, what: str, timeout: float):
    poll(lambda: (lambda n: (n == 1, f"{n} found"))(locator.count()), f"exactly one {what}", timeout, 0.2)
    return locator


def _labelled(text: str):
    return re.compile(r"^\s*" + re.escape(text) + r"\s*$")


def set_slider(page, label: str, value: float, timeout: float = 15.0) -> str:
    """Type ``value`` into the readout of the ipywidgets slider labelled ``label`` and press Enter, as a person
    does; wait until the readout shows it. Returns the readout."""
    slider = _only(page.locator(".widget-slider").filter(
        has=page.locator(".widget-label:not(.widget-readout)", has_text=_labelled(label))), f"slider {label!r}", timeout)
    readout = slider.locator(".widget-readout")
    readout.scroll_into_view_if_needed()
    readout.click()
    readout.fill(str(value))
    readout.press("Enter")

    def shows():
        text = readout.inner_text().strip()
        try:
            shown = float(text.replace("\u2212", "-"))
        except ValueError:
            return False, text
        places = len(text.split(".")[1]) if "." in text else 0
        return abs(shown - float(value)) <= 0.5 * 10 ** -places + 1e-9, text

    return poll(shows, f"slider {label!r} to show {value}", timeout)


def step_slider(page, label: str, steps: int, timeout: float = 15.0) -> None:
    """Move the slider labelled ``label`` by ``steps`` stops with the arrow keys on its handle, as a person does
    (a selection slider, such as the panel's blade count, takes no typed value)."""
    slider = _only(page.locator(".widget-slider").filter(
        has=page.locator(".widget-label:not(.widget-readout)", has_text=_labelled(label))), f"slider {label!r}", timeout)
    handle = slider.locator(".noUi-handle").first
    handle.scroll_into_view_if_needed()
    handle.focus()
    for _ in range(abs(steps)):
        page.keyboard.press("ArrowRight" if steps > 0 else "ArrowLeft")


def click_button(page, text: str, timeout: float = 15.0) -> None:
    """Click the ipywidgets button whose text is ``text``."""
    _only(page.locator("button.jupyter-button").filter(has_text=_labelled(text)), f"button {text!r}", timeout).click()


def set_checkbox(page, label: str, value: bool, timeout: float = 15.0) -> None:
    """Check (or uncheck) the ipywidgets checkbox labelled ``label``."""
    box = _only(page.locator(".widget-checkbox").filter(
        has=page.locator(".widget-label-basic span", has_text=_labelled(label))), f"checkbox {label!r}", timeout)
    box.locator("input[type=checkbox]").set_checked(bool(value))
