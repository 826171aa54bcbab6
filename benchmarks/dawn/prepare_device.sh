#!/usr/bin/env bash
# Prepare, here in the project root, what the GPU machine needs to run the browser engine's Dawn
# benchmark (benchmarks/dawn/run_engine.mjs); that machine has no network, no node, no Vulkan loader.
#   .device/dawn/common.tar.xz     node (this machine's, the nodesource 20 build: needs only glibc and
#                                  libstdc++), dawn.node + index.js of the npm package webgpu 0.6.2,
#                                  Debian's libvulkan1 loader, the engine module (BrowserEngineWidget._esm)
#   .device/dawn/case_<N>.tar.xz   per blade count: the traits GrassWidget(N, preset="meadow",
#                                  backend="browser") sends at 1920x1080 when its page reports a GPU (the
#                                  meadow as shipped: to the horizon, the sunlight on) and the kernel
#                                  engine's picture and count of blades drawn of the same state
# .device/ is ignored by git. It prints the run calls: what to carry and the command
# (benchmarks/dawn/run_on_device.sh, which unpacks with Python's lzma and runs node on NVIDIA's Vulkan).
#   .device/dawn-wheels/           with --matrix: Python 3.12 wheels of the widget's side of
#                                  browser_engine_dawn.py --matrix (run there by benchmarks/dawn/matrix_on_device.sh)
# Usage: bash benchmarks/dawn/prepare_device.sh [--matrix] [BLADE COUNTS...]   (default 65536 262144 1048576)
set -euo pipefail
DEST=.device/dawn
PY=${PYTHON:-.venv/bin/python}
[ -x "$PY" ] || PY=python3
if [ "${1:-}" = "--matrix" ]; then
  shift
  WHEELS=.device/dawn-wheels
  mkdir -p "$WHEELS"
  PLAT=""
  for p in manylinux_2_28_x86_64 manylinux_2_27_x86_64 manylinux_2_17_x86_64 manylinux2014_x86_64; do PLAT="$PLAT --platform $p"; done
  # the widget's imports (grasswidget.browser needs no GPU package): pinned to this machine's versions
  PINS=$("$PY" - <<'PY'
from importlib.metadata import version
names = ["numpy", "traitlets", "jinja2", "markupsafe", "anywidget", "ipywidgets", "comm", "ipython", "pygments",
         "psygnal", "typing_extensions"]
print(" ".join(f"{n}=={version(n)}" for n in names))
PY
)
  # shellcheck disable=SC2086
  python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp $PLAT \
    -d "$WHEELS" $PINS
  ls -la "$WHEELS"
fi
COUNTS=${*:-"65536 262144 1048576"}
NODE=$(command -v node)
mkdir -p "$DEST"
rm -f "$DEST"/*.tar.xz
VK=$(mktemp -d)
(cd "$VK" && { apt-get download libvulkan1 >/dev/null 2>&1 || { apt-get update -qq && apt-get download libvulkan1; }; } \
   && dpkg-deb -x libvulkan1_*.deb root && rm -f libvulkan1_*.deb)
# shellcheck disable=SC2086
PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH} "$PY" benchmarks/browser_engine_dawn.py --bundle "$DEST" \
  --blades $COUNTS --size 1920x1080 --node "$NODE" --vulkan "$VK/root"
rm -rf "$VK"
ls -la "$DEST"
