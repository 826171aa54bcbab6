#!/usr/bin/env bash
# Set up grasswidget on a fresh Debian/Ubuntu machine and run it.
#   ./run.sh demo   install everything, then open the tour notebook in JupyterLab
#   ./run.sh test   install everything, then run the whole test suite (CPU Vulkan is enough)
#   ./run.sh snapshot OUT.png [args]   install, then render a snapshot from the command line
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
VENV=${GRASSWIDGET_VENV:-.venv}

install() {
  local pkgs="python3 python3-venv python3-pip mesa-vulkan-drivers libvulkan1 chromium"
  local missing=""
  for p in $pkgs; do dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"; done
  if [ -n "$missing" ]; then
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing >/dev/null
  fi
  [ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
  "$VENV/bin/python" -m pip install -q --upgrade pip
  "$VENV/bin/python" -m pip install -q -e ".[test]"
  export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}
  mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
}

cmd=${1:-demo}
shift || true
case "$cmd" in
  demo)
    install
    if [ -f notebooks/01_tour.ipynb ]; then
      exec "$VENV/bin/jupyter" lab notebooks/01_tour.ipynb "$@"
    fi
    exec "$VENV/bin/python" -m grasswidget snapshot grass.png "$@"
    ;;
  test)
    install
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
