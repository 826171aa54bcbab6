#!/usr/bin/env bash
# Set up grasswidget on a fresh Debian/Ubuntu machine and run it.
#   ./run.sh demo   install everything, then open the tour notebook in JupyterLab
#                   (as root too; with no display it opens no browser and JupyterLab prints the URL;
#                   extra arguments go to JupyterLab, e.g. ./run.sh demo --port=8899 --ip=0.0.0.0)
#   ./run.sh test   install everything, then run the whole test suite (CPU Vulkan is enough)
#   ./run.sh snapshot OUT.png [args]   install, then render a snapshot from the command line
# GRASSWIDGET_VENV=DIR picks the virtual environment (default .venv); GRASSWIDGET_SKIP_INSTALL=1 skips
# the apt/pip step (the tests use it to start the demo exactly as here, without reinstalling).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
VENV=${GRASSWIDGET_VENV:-.venv}

runtime_dir() {
  # The Vulkan loader wants a private runtime dir (mode 0700) or it complains on every start.
  if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "$XDG_RUNTIME_DIR" ]; then
    export XDG_RUNTIME_DIR="${TMPDIR:-/tmp}/grasswidget-runtime-$(id -u)"
    mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
  fi
}

install() {
  runtime_dir
  if [ "${GRASSWIDGET_SKIP_INSTALL:-0}" = 1 ]; then return; fi
  local pkgs="python3 python3-venv python3-pip mesa-vulkan-drivers libvulkan1 chromium nodejs"
  local missing=""
  for p in $pkgs; do dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"; done
  if [ -n "$missing" ]; then
    if [ -n "$SUDO" ] && ! command -v sudo >/dev/null 2>&1; then
      echo "run.sh: these Debian packages are missing:$missing. Install them as root" \
           "(apt-get install -y$missing), or run ./run.sh as root, then run it again." >&2
      exit 1
    fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing >/dev/null
  fi
  [ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
  "$VENV/bin/python" -m pip install -q --upgrade pip
  "$VENV/bin/python" -m pip install -q -e ".[test]"
}

test_tools() {
  # TypeScript checks the package's JavaScript in the suite (tests/browser/test_js_types.py): a test
  # tool only, pinned in package.json / package-lock.json, installed into ./node_modules. Debian's
  # nodejs comes without npm (its own package); NodeSource's nodejs has it.
  if [ "${GRASSWIDGET_SKIP_INSTALL:-0}" = 1 ]; then return; fi
  if ! command -v npm >/dev/null 2>&1; then
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq npm >/dev/null
  fi
  npm ci --no-audit --no-fund --loglevel=error
}

lab() {
  # JupyterLab refuses to run as root without --allow-root (containers, fresh VMs run as root);
  # on a server without a display there is no browser to open: JupyterLab prints the URL instead.
  local args=(lab notebooks/01_tour.ipynb)
  if [ "$(id -u)" = 0 ]; then args+=(--allow-root); fi
  if [ -z "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ] && [ "$(uname -s)" != Darwin ]; then
    args+=(--no-browser)
    echo "run.sh: no display here, so no browser is opened: open the http://127.0.0.1:... URL with its token" \
         "that JupyterLab prints below (over ssh: ssh -L 8888:127.0.0.1:8888 this-host first)." >&2
  fi
  exec "$VENV/bin/jupyter" "${args[@]}" "$@"
}

cmd=${1:-demo}
shift || true
case "$cmd" in
  demo)
    install
    if [ -f notebooks/01_tour.ipynb ]; then lab "$@"; fi
    exec "$VENV/bin/python" -m grasswidget snapshot grass.png "$@"
    ;;
  test)
    install
    test_tools
    exec "$VENV/bin/python" -m pytest -q "$@"
    ;;
  snapshot)
    install
    exec "$VENV/bin/python" -m grasswidget snapshot "$@"
    ;;
  *)
    echo "usage: ./run.sh demo | test | snapshot OUT.png [--blades N --size WxH --steps K]" >&2
    exit 2
    ;;
esac
