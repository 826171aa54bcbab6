#!/usr/bin/env bash
# The suite's GPU-facing tests on a machine with a real GPU and no network (the GPU machine: an
# NVIDIA H100/H200, Python 3.12 with numpy, no package index, no Vulkan loader).
#
# Two steps, the first here (a machine with pip, apt and this checkout's virtual environment):
#
#   bash tests/run_on_gpu.sh prepare [DIR]
#       fills DIR (default .gpu-suite/ in the checkout's root; git ignores it) with
#         wheels/   Python 3.12 manylinux wheels of everything the tests import: the package's own
#                   dependencies, pytest and the build backend hatchling (the packaging tests build
#                   the wheel), each pinned to the version installed here, found by walking the
#                   installed packages' requirements (numpy excepted: the GPU machine has it);
#         vulkan/   the Vulkan loader (Debian's libvulkan1, unpacked);
#         env.sh    installs the wheels into /tmp/gpu-suite-site and points the loader at NVIDIA's
#                   driver (on the headless machine its EGL library carries the Vulkan entry points).
#       About 30 MB. DIR travels with the checkout (the device tool: carry it).
#
#   bash tests/run_on_gpu.sh run [DIR] [OUT] [-- PYTEST ARGS]
#       there, from the checkout's root: sources DIR/env.sh, prints the adapter wgpu chose (it
#       must be the GPU, not a CPU fallback: the run stops otherwise), then runs
#       pytest -m "not browser" tests/core tests/gpu tests/tools  (or PYTEST ARGS)
#       writing OUT/gpu-suite.log (the whole output), OUT/gpu-suite-junit.xml,
#       OUT/gpu-suite-times.log (each test's time, tests/conftest.py) and OUT/gpu-suite-pictures.tar
#       (the pictures tests save with conftest.save_test_picture, to be looked at here). OUT defaults to $OUT (the
#       device tool's folder that comes back) or gpu-suite-out/. Exit status: pytest's.
#       About 100 s on an H200. Tests that need the network (installing the built wheel's
#       dependencies from an index) skip there, saying why; every other test must pass, as on
#       lavapipe: a picture test whose bound differs per adapter says so in its docstring.
#
# With the device tool (see tests/README.md): after `prepare`, call run with carry [".gpu-suite"]
# and the command `bash tests/run_on_gpu.sh run`.
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT" || exit 2
STEP=${1:-}
shift || true

case "$STEP" in
prepare)
  DIR=${1:-.gpu-suite}
  PY=${PY:-$ROOT/.venv/bin/python}
  [ -x "$PY" ] || PY=$(command -v python3)
  mkdir -p "$DIR/wheels" "$DIR/vulkan" || exit 2
  # every distribution the tests import, with the versions installed here: the package's
  # requirements (no extras), pytest and hatchling, and theirs, for Linux x86-64 and Python 3.12
  PINS=$("$PY" - <<'PYCODE'
import re
from importlib import metadata
from packaging.requirements import Requirement

env = {"python_version": "3.12", "python_full_version": "3.12.3", "sys_platform": "linux",
       "platform_system": "Linux", "platform_machine": "x86_64", "os_name": "posix",
       "implementation_name": "cpython", "platform_python_implementation": "CPython", "extra": ""}
root = Requirement("grasswidget")
todo = [Requirement(r) for r in ("pytest", "hatchling")]
todo += [Requirement(r) for r in (metadata.requires("grasswidget") or [])]
seen, pins = set(), []
while todo:
    req = todo.pop()
    name = re.sub(r"[-_.]+", "-", req.name).lower()
    if name in seen or name == "numpy" or (req.marker is not None and not req.marker.evaluate(env)):
        continue
    seen.add(name)
    try:
        dist = metadata.distribution(req.name)
    except metadata.PackageNotFoundError:
        raise SystemExit(f"{req.name} is needed but not installed here: pip install -e .[test] first")
    pins.append(f"{req.name}=={dist.version}")
    todo += [Requirement(r) for r in (dist.requires or [])]
print(" ".join(sorted(pins)))
PYCODE
) || exit 2
  echo "wheels: $PINS"
  PLATFORMS=""
  for p in manylinux_2_28_x86_64 manylinux_2_27_x86_64 manylinux_2_17_x86_64 manylinux2014_x86_64 manylinux1_x86_64; do
    PLATFORMS="$PLATFORMS --platform $p"
  done
  # shellcheck disable=SC2086
  "$PY" -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
    $PLATFORMS -d "$DIR/wheels" $PINS || exit 2
  if [ ! -e "$DIR/vulkan/root/usr/lib/x86_64-linux-gnu/libvulkan.so.1" ]; then
    (cd "$DIR/vulkan" && { apt-get download libvulkan1 >/dev/null 2>&1 || { apt-get update -qq && apt-get download libvulkan1; }; } \
      && dpkg-deb -x libvulkan1_*.deb root && rm -f libvulkan1_*.deb) || exit 2
  fi
  cat > "$DIR/env.sh" <<'ENV'
# Sourced on the GPU machine from the checkout's root (tests/run_on_gpu.sh run does it).
_GS=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
  --target /tmp/gpu-suite-site "$_GS"/wheels/*.whl || return 1
export PYTHONPATH=/tmp/gpu-suite-site:$PWD${PYTHONPATH:+:$PYTHONPATH}
export PATH=/tmp/gpu-suite-site/bin:$PATH
export LD_LIBRARY_PATH=$_GS/vulkan/root/usr/lib/x86_64-linux-gnu:/usr/local/nvidia/lib64${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
printf '{"file_format_version":"1.0.1","ICD":{"library_path":"/usr/local/nvidia/lib64/libEGL_nvidia.so.0","api_version":"1.3"}}\n' > /tmp/gpu-suite-nvidia-icd.json
export VK_ICD_FILENAMES=/tmp/gpu-suite-nvidia-icd.json
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
export PYTHONUNBUFFERED=1
ENV
  du -sh "$DIR"
  echo "ready: carry $DIR and run: bash tests/run_on_gpu.sh run $DIR"
  ;;
run)
  DIR=.gpu-suite
  if [ $# -gt 0 ] && [ "$1" != "--" ]; then DIR=$1; shift; fi
  DEST=${OUT:-gpu-suite-out}
  if [ $# -gt 0 ] && [ "$1" != "--" ]; then DEST=$1; shift; fi
  [ "${1:-}" = "--" ] && shift
  [ -f "$DIR/env.sh" ] || { echo "$DIR/env.sh is missing: bash tests/run_on_gpu.sh prepare $DIR first (here)"; exit 2; }
  # shellcheck disable=SC1091
  source "$DIR/env.sh" || { echo "installing the carried wheels failed"; exit 2; }
  mkdir -p "$DEST"
  command -v nvidia-smi >/dev/null && nvidia-smi -L
  python3 - <<'PYCODE' || exit 3
from grasswidget.gpu.adapter import adapter_info, is_cpu_adapter

info = adapter_info()
print(f"adapter: {info.get('summary')} (driver {info.get('description')})")
if is_cpu_adapter():
    raise SystemExit("wgpu chose a CPU adapter: the GPU's Vulkan driver was not found (see env.sh)")
PYCODE
  if [ $# -eq 0 ]; then set -- -m "not browser" tests/core tests/gpu tests/tools; fi
  # pictures the tests save (conftest.save_test_picture) come back in one file
  GW_TEST_PICTURES="$DEST/pictures" GW_TEST_TIMES="$DEST/gpu-suite-times.log" python3 -m pytest -q -p no:cacheprovider -rfEs \
    --junitxml="$DEST/gpu-suite-junit.xml" "$@" 2>&1 | tee "$DEST/gpu-suite.log"
  status=${PIPESTATUS[0]}
  if [ -d "$DEST/pictures" ]; then
    tar cf "$DEST/gpu-suite-pictures.tar" -C "$DEST" pictures && rm -rf "$DEST/pictures"
  fi
  echo "pytest exit status $status; log: $DEST/gpu-suite.log"
  exit "$status"
  ;;
*)
  sed -n '2,31p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
  exit 2
  ;;
esac
