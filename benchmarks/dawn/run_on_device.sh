#!/usr/bin/env bash
# On the GPU machine, from the project root, with .device/dawn/*.tar.xz carried (see prepare_device.sh):
# unpack what is new into /tmp/gw-dawn (kept while the machine stays warm, so a second call may carry
# only the next case), point the Vulkan loader at NVIDIA's driver, run every carried case.
# CASES="N ..." runs only those blade counts. Results: $OUT (default benchmarks/.dawn/out)/
# browser_engine_dawn_<case>-$MACHINE-<date>.json (MACHINE default gpu, e.g. MACHINE=h200; the name
# benchmarks/results/ wants) and the frames read back (.rgba) beside them.
set -euo pipefail
U=/tmp/gw-dawn
OUT_DIR=${OUT:-benchmarks/.dawn/out}
mkdir -p "$U" "$OUT_DIR"
python3 - "$U" .device/dawn/*.tar.xz <<'PY'
import sys, tarfile, pathlib
dest = pathlib.Path(sys.argv[1])
for f in sys.argv[2:]:
    mark = dest / (pathlib.Path(f).name + ".done")
    if not mark.exists():
        with tarfile.open(f, "r:xz") as tar:
            tar.extractall(dest)
        mark.touch()
        print("unpacked", f)
PY
chmod +x "$U/node/node"
export LD_LIBRARY_PATH=$U/vulkan/usr/lib/x86_64-linux-gnu:/usr/local/nvidia/lib64${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
printf '{"file_format_version":"1.0.1","ICD":{"library_path":"/usr/local/nvidia/lib64/libEGL_nvidia.so.0","api_version":"1.3"}}\n' > /tmp/nvidia_icd.json
export VK_ICD_FILENAMES=${VK_ICD_FILENAMES:-/tmp/nvidia_icd.json} XDG_RUNTIME_DIR=/tmp
for f in .device/dawn/case_*.tar.xz; do
  n=$(basename "$f" .tar.xz); n=${n#case_}
  if [ -n "${CASES:-}" ] && [[ " $CASES " != *" $n "* ]]; then continue; fi  # CASES="1048576": only those
  "$U/node/node" benchmarks/dawn/run_engine.mjs --manifest "$U/states/manifest_$n.json" \
    --out "$OUT_DIR/browser_engine_dawn_$n-${MACHINE:-gpu}-$(date -u +%F).json" --dawn "$U/webgpu" --seconds "${SECONDS_MEASURED:-5}"
done
