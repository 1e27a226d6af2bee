#!/usr/bin/env bash
# Here (with bpy), before bench/gpu_check.sh runs on the GPU machine: the wheels and GL
# loaders that machine lacks (../shared/gpu/prepare.sh), the scenes as USD files (that
# machine has no bpy), and llvmpipe's images of them to compare its own with.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
../shared/gpu/prepare.sh
[ -f out/demo.usdc ] || make demo
$PY bench/bench_gpu.py prepare .gpu/scenes
$PY bench/bench_gpu.py run .gpu/scenes --sizes 640x360 --presets medium --forms compute \
    --images .gpu/ref46
du -sh .gpu
echo "ready: device command 'bash .gpu/run.sh bash bench/gpu_check.sh', carry [\".gpu\"]"
