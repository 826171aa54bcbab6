"""Debian's headless Chromium through Playwright (sync API): its flags, :class:`Browser`, and
what to keep of a page after a failure.

Each :class:`Browser` gets a fresh private user-data directory, so nothing of an earlier run
leaks in; Playwright's one instance per process is shared by every Browser.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Optional

from .polling import HarnessError

if TYPE_CHECKING:
    from .servers import JupyterLabServer


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
