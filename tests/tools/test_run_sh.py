"""The README's demo command starts JupyterLab, as root too, with no display.

``./run.sh demo`` is started exactly as a user starts it (the same script, the same
``jupyter lab`` command line), except that ``GRASSWIDGET_SKIP_INSTALL=1`` skips the
apt/pip step (the suite already runs inside that environment) and a port and a
token are passed through to JupyterLab. The test waits until the server answers
``/api/status`` and serves the tour notebook, then stops it.
"""

import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytest.importorskip("jupyterlab")


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _get(url):
    try:
        with urllib.request.urlopen(url, timeout=5) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as err:
        return err.code, b""
    except (urllib.error.URLError, ConnectionError, socket.timeout):
        return None, b""


@pytest.mark.slow
def test_demo_command_starts_jupyterlab_that_answers(tmp_path):
    port = _free_port()
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "JUPYTER_TOKEN")}
    env.update(
        GRASSWIDGET_SKIP_INSTALL="1",
        GRASSWIDGET_VENV=sys.prefix,  # the environment running this test
        JUPYTER_CONFIG_DIR=str(tmp_path / "config"),
        JUPYTER_RUNTIME_DIR=str(tmp_path / "runtime"),
        JUPYTER_DATA_DIR=str(tmp_path / "data"),
        IPYTHONDIR=str(tmp_path / "ipython"),
    )
    log_path = tmp_path / "demo.log"
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(
            [str(ROOT / "run.sh"), "demo", f"--port={port}", "--ServerApp.port_retries=0",
             "--LabApp.news_url=None", "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate"],
            cwd=tmp_path, env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        # Headless: no browser is opened; the URL to open, with its generated token, is printed.
        # Read it from the output as a user would, and use it.
        url_re = re.compile(rf"http://127\.0\.0\.1:{port}/lab\?token=([0-9a-f]{{16,}})")
        deadline = time.monotonic() + 120
        token = None
        while token is None and time.monotonic() < deadline:
            if proc.poll() is not None:
                pytest.fail(f"./run.sh demo exited with {proc.returncode}:\n{log_path.read_text()[-3000:]}")
            m = url_re.search(log_path.read_text())
            token = m.group(1) if m else None
            time.sleep(0.25)  # polling interval, not a stand-in for a check
        log_text = log_path.read_text()
        assert token, f"no URL with a token printed within 120 s:\n{log_text[-3000:]}"
        assert "no display here" in log_text
        if os.getuid() == 0:
            assert "Running as root is not recommended" not in log_text
        base = f"http://127.0.0.1:{port}"
        status = None
        while status != 200 and time.monotonic() < deadline:
            status, body = _get(f"{base}/api/status?token={token}")
        assert status == 200 and b"started" in body
        # it serves the tour notebook it was asked to open (JupyterLab roots itself at the notebook's folder)
        status, body = _get(f"{base}/api/contents/01_tour.ipynb?content=0&token={token}")
        assert status == 200 and b'"01_tour.ipynb"' in body
        status, _ = _get(f"{base}/api/status")  # the token is required
        assert status in (401, 403)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGTERM)  # the group this test started (jupyter and its children)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10)
