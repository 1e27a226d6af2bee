#!/usr/bin/env bash
# The checks that need an NVIDIA GPU, in one call of the `device` tool (docs/gpu.md).
# Here, before it:
#   ../shared/gpu/prepare.sh
#   .venv/bin/python bench/bench_gpu.py prepare .gpu/scenes
#   .venv/bin/python bench/bench_gpu.py run .gpu/scenes --sizes 640x360 --presets medium --images .gpu/ref46
#   LANTERN_MAX_GL=33 .venv/bin/python bench/bench_gpu.py run .gpu/scenes --sizes 640x360 \
#       --presets medium --images .gpu/ref33
# Then the device command `bash .gpu/run.sh bash bench/gpu_check.sh`, carrying [".gpu"].
# Back in $OUT: log.txt, gpu.json (frame times) and nvidia_640x360.npz (the images, half floats).
set -u
OUT=${OUT:-/tmp/gpu-check}; mkdir -p "$OUT"
exec > >(tee "$OUT/log.txt") 2>&1
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || true

echo "== the images against llvmpipe's: GL 4.x paths, then GL 3.3's"
timeout 90 python3 bench/bench_gpu.py run .gpu/scenes --sizes 640x360 --presets medium --images /tmp/img46
python3 bench/bench_gpu.py compare .gpu/ref46 /tmp/img46
LANTERN_MAX_GL=33 timeout 90 python3 bench/bench_gpu.py run .gpu/scenes --sizes 640x360 \
    --presets medium --images /tmp/img33
python3 bench/bench_gpu.py compare .gpu/ref33 /tmp/img33
python3 - "$OUT/nvidia_640x360.npz" <<'PY'
import pathlib, sys
import numpy as np
images = {f"{d[-2:]}_{p.stem}": np.load(p)["rgba"].astype(np.float16)
          for d in ("/tmp/img46", "/tmp/img33") for p in pathlib.Path(d).glob("*.npz")}
np.savez_compressed(sys.argv[1], **images)
PY

echo "== cold start: lantern render in new processes against a warm Session.render"
timeout 100 python3 bench/bench_cold.py --parts cli --runs 3 --baseline none --demo .gpu/scenes/demo.usdc

echo "== frame times: medium at each size, then low, high and ultra at 1920x1080"
timeout 150 python3 bench/bench_gpu.py run .gpu/scenes --presets medium --json "$OUT/gpu.json"
timeout 100 python3 bench/bench_gpu.py run .gpu/scenes --sizes 1920x1080 --presets low high ultra \
    --json "$OUT/gpu_presets.json"

echo "== the engine tests that need no bpy"
PYTHONPATH=tests:$PYTHONPATH timeout 130 python3 -m pytest --noconftest -p no:cacheprovider -q \
    -n 8 --continue-on-collection-errors \
    tests/test_bump_correction.py tests/test_cold_start.py tests/test_engine_calibration.py \
    tests/test_engine_image_io.py tests/test_engine_scenes.py tests/test_engine_textures.py \
    tests/test_fragments.py tests/test_light_volumes.py tests/test_overlays.py \
    tests/test_readback.py tests/test_reference_scenes.py tests/test_shading.py \
    tests/test_tessellation.py tests/test_transparency.py tests/test_shadows.py \
    tests/test_program_cache.py tests/test_many_lights.py tests/test_area_shadows.py \
    tests/test_render_passes.py 2>&1 | tail -40
echo "== done"
