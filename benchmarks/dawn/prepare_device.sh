#!/usr/bin/env bash
# Prepare, here in the project root, what the GPU machine needs to run the browser engine's Dawn
# benchmark (benchmarks/dawn/run_engine.mjs); that machine has no network, no node, no Vulkan loader.
#   .device/dawn/common.tar.xz     node (this machine's, the nodesource 20 build: needs only glibc and
#                                  libstdc++), dawn.node + index.js of the npm package webgpu 0.6.2,
#                                  Debian's libvulkan1 loader, the engine module (BrowserView._esm)
#   .device/dawn/case_<N>.tar.xz   per blade count: the traits a BrowserView sends for the meadow preset
#                                  at 1920x1080 and the kernel engine's picture of the same state
# .device/ is ignored by git. It prints the run calls: what to carry and the command
# (benchmarks/dawn/run_on_device.sh, which unpacks with Python's lzma and runs node on NVIDIA's Vulkan).
# Usage: bash benchmarks/dawn/prepare_device.sh [BLADE COUNTS...]   (default 65536 262144 1048576)
set -euo pipefail
DEST=.device/dawn
COUNTS=${*:-"65536 262144 1048576"}
PY=${PYTHON:-.venv/bin/python}
[ -x "$PY" ] || PY=python3
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
