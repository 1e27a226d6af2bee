#!/usr/bin/env bash
# The read-back's modes and compute skinning on an NVIDIA GPU, in one call of the
# `device` tool (about 6 minutes at most; docs/gpu.md). Here, before it, as for gpu_check.sh:
#   ../shared/gpu/prepare.sh
#   .venv/bin/python bench/bench_gpu.py prepare .gpu/scenes
# Then the device command `bash .gpu/run.sh bash bench/gpu_check_readback_skinning.sh`,
# carrying [".gpu"]. Back in $OUT: log.txt, readback.json (bench_readback.py),
# gpu_direct.json and gpu_mapped.json (bench_gpu.py at 1080p and 4K, medium, in each
# read mode: the frame into a reused buffer and into a new array).
set -u
OUT=${OUT:-/tmp/gpu-check}; mkdir -p "$OUT"
exec > >(tee "$OUT/log.txt") 2>&1
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || true

echo "== skinning: compute against transform feedback (the tests that need no bpy or corpus)"
PYTHONPATH=tests:${PYTHONPATH:-} timeout 60 python3 -m pytest --noconftest -p no:cacheprovider \
    -q tests/test_skinning_compute.py -k "not usdskel" 2>&1 | tail -8
timeout 60 python3 bench/bench_skinning.py --quick

echo "== the read-back: each mode against one bare glReadPixels"
timeout 40 python3 bench/bench_readback.py --json "$OUT/readback.json"
PYTHONPATH=tests:${PYTHONPATH:-} timeout 30 python3 -m pytest --noconftest -p no:cacheprovider \
    -q tests/test_readback.py -k "read_modes or non_finite" 2>&1 | tail -4

echo "== frames in each read mode, 1080p and 4K, medium"
for mode in direct mapped; do
    LANTERN_READBACK=$mode timeout 100 python3 bench/bench_gpu.py run .gpu/scenes \
        --sizes 1920x1080 3840x2160 --presets medium \
        --json "$OUT/gpu_$mode.json"
done
echo "== done"
