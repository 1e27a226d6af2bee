#!/usr/bin/env bash
# Every check that needs an NVIDIA GPU, in one call of the `device` tool (docs/gpu.md):
# the devices, the images against llvmpipe's, frame times in each form (compute,
# volumes, raster) at 1080p and 4K, the demo at ultra, many lights against numpy's sum,
# each pass and dispatch alone, the read-back's modes, compute skinning against
# transform feedback, and the engine tests that need no bpy. About 4 minutes on an H100
# (2026-11-27); each step has its own time limit.
# Here, before it: bash bench/gpu_prepare.sh   (the wheels, the scenes, llvmpipe's images)
# Then the device command `bash .gpu/run.sh bash bench/gpu_check.sh`, carrying [".gpu"].
# Back in $OUT: log.txt, devices.txt, gpu.json, gpu_ultra.json, gpu_lights.json,
# readback.json, gpu_mapped.json and nvidia_640x360.npz (the images, half floats).
set -u
OUT=${OUT:-/tmp/gpu-check}; mkdir -p "$OUT"
exec > >(tee "$OUT/log.txt") 2>&1
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
# `timeout` runs programs, not shell functions: each step names its limit as the first argument.
run() { local limit=$1; shift; timeout "$limit" python3 bench/bench_gpu.py run .gpu/scenes "$@"; }

echo "== devices, the CPU warning, memory, frames too large (bench/gpu_devices.sh)"
OUT="$OUT" timeout 60 bash bench/gpu_devices.sh > /dev/null

echo "== the images against llvmpipe's (compute forms)"
run 60 --sizes 640x360 --presets medium --forms compute --images /tmp/img46
python3 bench/bench_gpu.py compare .gpu/ref46 /tmp/img46
python3 - "$OUT/nvidia_640x360.npz" <<'PY'
import pathlib, sys
import numpy as np
images = {p.stem: np.load(p)["rgba"].astype(np.float16) for p in pathlib.Path("/tmp/img46").glob("*.npz")}
np.savez_compressed(sys.argv[1], **images)
PY

echo "== frame times into a caller's buffer, medium, compute and raster forms"
run 140 --sizes 1920x1080 3840x2160 --presets medium --forms compute raster \
    --json "$OUT/gpu.json"
echo "== the demo at ultra, 1080p"
run 50 --scenes demo --sizes 1920x1080 --presets ultra --forms compute raster \
    --json "$OUT/gpu_ultra.json"
echo "== many lights at 1080p: 1, 256, 16,384 against numpy's sum"
run 60 --scenes --lights --forms compute volumes --json "$OUT/gpu_lights.json"

echo "== each pass and dispatch alone (glFinish around each; CPU + wait): one light and 16,384 over the plane, the demo"
timeout 90 python3 bench/bench_dispatches.py .gpu/scenes lights_1 lights_16384 demo

echo "== the read-back: each mode against one bare glReadPixels; the demo read mapped"
timeout 30 python3 bench/bench_readback.py --json "$OUT/readback.json"
LANTERN_READBACK=mapped run 30 --scenes demo --sizes 1920x1080 --presets medium \
    --forms compute --json "$OUT/gpu_mapped.json"
echo "== skinning alone: compute against transform feedback"
timeout 20 python3 bench/bench_skinning.py --quick

echo "== the engine tests that need no bpy (compute skinning, the light tree, read-back, ...)"
PYTHONPATH=tests:${PYTHONPATH:-} timeout 90 python3 -m pytest --noconftest -p no:cacheprovider -q \
    -n 8 --continue-on-collection-errors \
    tests/test_skinning_compute.py tests/test_light_tree.py tests/test_readback.py \
    tests/test_engine_calibration.py tests/test_light_volumes.py tests/test_engine_scenes.py \
    tests/test_shading.py tests/test_render_passes.py tests/test_many_lights.py \
    -k "not usdskel and not blender_pass_indices" 2>&1 | tail -30
echo "== done"
