#!/usr/bin/env bash
# On the GPU machine: issue 28's matrix through Dawn (benchmarks/browser_engine_dawn.py --matrix), with
# the Python widget answering the engine. Run from a folder holding, carried:
#   $DAWN_COMMON     common.tar.xz of benchmarks/dawn/prepare_device.sh (node, dawn.node, the Vulkan loader)
#   $DAWN_WHEELS     Python 3.12 wheels of the widget's side: numpy, traitlets, jinja2, markupsafe,
#                    anywidget, ipywidgets, comm, ipython, pygments, psygnal, typing_extensions
#                    (benchmarks/dawn/prepare_device.sh --matrix writes them)
#   $TREE            the project's tree (grasswidget/ and benchmarks/)
# ROWS="preset:blades:WxH ..." (default the script's MATRIX_ROWS), ROUNDS, WINDOW; results under $OUT.
set -euo pipefail
: "${DAWN_COMMON:=.device/dawn/common.tar.xz}" "${DAWN_WHEELS:=.device/dawn-wheels}" "${TREE:=$PWD}"
OUT_DIR=${OUT:-benchmarks/.dawn/out}
U=/tmp/gw-dawn
mkdir -p "$U" "$OUT_DIR"
python3 - "$U" "$DAWN_COMMON" <<'PY'
import sys, tarfile, pathlib
dest, f = pathlib.Path(sys.argv[1]), sys.argv[2]
mark = dest / (pathlib.Path(f).name + ".done")
if not mark.exists():
    with tarfile.open(f, "r:xz") as tar:
        tar.extractall(dest)
    mark.touch()
PY
chmod +x "$U/node/node"
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site-dawn "$DAWN_WHEELS"/*.whl
export PYTHONPATH=/tmp/site-dawn:$TREE PYTHONUNBUFFERED=1 XDG_RUNTIME_DIR=/tmp
export LD_LIBRARY_PATH=$U/vulkan/usr/lib/x86_64-linux-gnu:/usr/local/nvidia/lib64${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
printf '{"file_format_version":"1.0.1","ICD":{"library_path":"/usr/local/nvidia/lib64/libEGL_nvidia.so.0","api_version":"1.3"}}\n' > /tmp/nvidia_icd.json
export VK_ICD_FILENAMES=/tmp/nvidia_icd.json
(cd /tmp && python3 -c "import grasswidget, sys; print(sys.version.split()[0], grasswidget.__file__)")
# shellcheck disable=SC2086
python3 "$TREE/benchmarks/browser_engine_dawn.py" --matrix --node "$U/node/node" --dawn "$U/webgpu" \
  ${ROWS:+--rows $ROWS} ${ROUNDS:+--rounds $ROUNDS} ${WINDOW:+--window $WINDOW} \
  --out "$OUT_DIR/browser_matrix_dawn-${MACHINE:-gpu}-$(date -u +%F).json"
