"""pytest fixtures for real-browser tests (JupyterLab + headless Chromium).

Fixtures:

* ``browser_root``  session-wide directory that JupyterLab serves; tests
  write their notebooks into it (use a unique file name per test).
* ``lab_server``    session-wide :class:`JupyterLabServer` on ``browser_root``.
* ``browser``       session-wide :class:`Browser` (Chromium, fresh profile).
* ``webgpu_browser`` a Chromium with WebGPU (SwiftShader) for one test: one browser
  (``webgpu_chromium``, session-wide) serves every test; after each test its page is
  back at its first viewport size.
* ``page``          the browser's page for one test; after the test its notebook is
  closed in Lab (Lab stays loaded for the next test's notebook:
  ``notebook_actions.leave_notebook``), its kernel is reset and kept for the next test's notebook (every
  other kernel is shut down: ``JupyterLabServer.shutdown_kernels``) and, on
  failure, a screenshot, the browser console and the server log are saved (path
  printed in the report); a failed test's kernel is not kept.

Tests in this folder that use one of these fixtures are marked ``browser`` automatically and are skipped
with a reason when Chromium or a needed package is missing. Deselect them
with ``-m "not browser"``.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

from .chromium import Browser, prerequisites_missing, save_debug_artifacts
from .notebook_actions import leave_notebook
from .servers import JupyterLabServer

_HERE = Path(__file__).resolve().parent


def pytest_configure(config):
    config.addinivalue_line("markers", "browser: real-browser test (JupyterLab + Chromium via Playwright)")


#: Fixtures that start JupyterLab or Chromium: a test of this folder using one is a real-browser test.
#: The others here (test_engine_without_a_browser.py) check the engine's Python side and run everywhere.
CHROMIUM_FIXTURES = {"browser", "webgpu_browser", "webgpu_chromium", "page", "lab_server", "browser_root"}


def pytest_collection_modifyitems(config, items):
    reason = prerequisites_missing()
    for item in items:
        if _HERE in Path(item.path).resolve().parents and CHROMIUM_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.browser)
            if reason:
                item.add_marker(pytest.mark.skip(reason=f"browser test prerequisites missing: {reason}"))


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_makereport(item, call):
    rep = yield
    setattr(item, f"gw_report_{rep.when}", rep)
    return rep


@pytest.fixture(scope="session")
def browser_root(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("lab-root")


@pytest.fixture(scope="session")
def lab_server(browser_root):
    server = JupyterLabServer(browser_root, reuse_kernels=True)
    server.start()
    try:
        yield server
    finally:
        server.stop()
        if os.environ.get("GW_KEEP_LAB_STATE") != "1":
            server.cleanup()


@pytest.fixture(autouse=True)
def _kernel_reuse(request):
    """The session's JupyterLab keeps the last test's kernel, reset, for the next notebook
    (``JupyterLabServer.shutdown_kernels``); a module with ``FRESH_KERNELS = True`` opens
    each notebook on a new kernel (one that has run nothing, started while the notebook
    before ran: ``JupyterLabServer.start_spare_kernel``), and after a failed test the kept
    kernel is shut down."""
    if "lab_server" not in request.fixturenames:
        yield
        return
    server = request.getfixturevalue("lab_server")
    fresh = bool(getattr(request.module, "FRESH_KERNELS", False))
    if fresh:
        server.drop_warm_kernel()
        server.reuse_kernels = False
        server.spare_kernels = True  # the next notebook's new kernel starts while this one runs
    else:
        server.drop_spare_kernel()
    try:
        yield
    finally:
        server.reuse_kernels = True
        server.spare_kernels = False
        if any(getattr(getattr(request.node, f"gw_report_{when}", None), "failed", False)
               for when in ("setup", "call")):
            server.drop_warm_kernel()


@pytest.fixture(scope="session")
def browser():
    with Browser() as b:
        yield b


@pytest.fixture(scope="session")
def webgpu_chromium():
    """Chromium with the WebGPU flags (SwiftShader), started once for the session."""
    with Browser(webgpu=True) as b:
        yield b


@pytest.fixture
def webgpu_browser(webgpu_chromium):
    """The session's WebGPU Chromium for one test; afterwards its page has its first
    viewport size again (a test may have made it larger)."""
    yield webgpu_chromium
    width, height = webgpu_chromium.viewport
    page = webgpu_chromium.page
    if page.viewport_size != {"width": width, "height": height}:
        page.set_viewport_size({"width": width, "height": height})


@pytest.fixture
def page(browser, lab_server, request):
    page = browser.page
    n_console = len(browser.console)
    yield page
    rep = getattr(request.node, "gw_report_call", None)
    if rep is not None and rep.failed:
        out = Path(os.environ.get("GW_ARTIFACTS_DIR") or tempfile.mkdtemp(prefix="gw-browser-failure-"))
        save_debug_artifacts(page, out, request.node.name, browser, lab_server)
        tail = "\n".join(browser.console[n_console:][-40:])
        print(f"\n[browser harness] debug artifacts in {out}\n[browser console tail]\n{tail}")
    # Leave a clean server for the next test: every kernel shut down but one, reset and kept; the
    # notebook closed in Lab, which stays loaded for the next test (reloaded after a failure).
    try:
        leave_notebook(page, lab_server, reload=rep is None or rep.failed)
    except Exception as exc:  # teardown must not mask the test result
        print(f"[browser harness] cleanup after {request.node.name} failed: {exc!r}")
