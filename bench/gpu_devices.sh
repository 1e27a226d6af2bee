#!/usr/bin/env bash
# The GPU device checks in one call of the `device` tool (docs/gpu.md, "Devices"): the
# EGL devices and their renderers, a render and a two-worker sequence that must draw on
# the GPU (LANTERN_REQUIRE_GPU=1) and say which device, the driver's memory figures, and
# frames too large for the device refused before drawing. About a minute.
# Here, before it:   ../shared/gpu/prepare.sh
# Then the device command `bash .gpu/run.sh bash bench/gpu_devices.sh`, carrying [".gpu"].
# Back in $OUT: devices.txt (everything printed).
set -u
OUT=${OUT:-/tmp/gpu-devices}; mkdir -p "$OUT"
exec > >(tee "$OUT/devices.txt") 2>&1
export LANTERN_REQUIRE_GPU=1 COLUMNS=200
work=$(mktemp -d)
nvidia-smi --query-gpu=index,name,memory.total,memory.used --format=csv,noheader || true

# A cube, a camera and a light: a stage that needs no Blender.
cat > "$work/cube.usda" <<'USDA'
#usda 1.0
(
    defaultPrim = "root"
    upAxis = "Z"
    metersPerUnit = 1
)
def Xform "root"
{
    def Mesh "Cube"
    {
        int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
        int[] faceVertexIndices = [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5]
        point3f[] points = [(-1, -1, -1), (1, -1, -1), (-1, 1, -1), (1, 1, -1), (-1, -1, 1), (1, -1, 1), (-1, 1, 1), (1, 1, 1)]
        uniform token subdivisionScheme = "none"
    }
    def Camera "Camera"
    {
        float focalLength = 35
        float horizontalAperture = 36
        float verticalAperture = 20.25
        float2 clippingRange = (0.1, 100)
        float3 xformOp:rotateXYZ = (70, 0, 30)
        double3 xformOp:translate = (4, -7, 4)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    }
    def SphereLight "Light"
    {
        float inputs:intensity = 1000
        double3 xformOp:translate = (2, -2, 4)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
USDA

echo "== lantern render --gpu list"
timeout 60 python3 -m lantern render --gpu list; echo "exit $?"
echo "== EGL devices as the engine sees them, and where -j workers 0-3 would draw"
timeout 60 python3 -c "
from lantern.engine.gpu import devices
print(devices.egl_devices()); print([devices.spread(k, devices.egl_devices()) for k in range(4)])"

echo "== one frame on --gpu 0 (a GPU is required: llvmpipe would be exit 1)"
timeout 60 python3 -m lantern render "$work/cube.usda" -o "$work/cube.exr" --size 640x360 --gpu 0 --debug
echo "exit $?"
echo "== a device that does not exist: exit 2, naming the devices"
timeout 60 python3 -m lantern render "$work/cube.usda" -o "$work/none.exr" --gpu 7; echo "exit $?"

echo "== a sequence on two local workers: both on device 0 (one GPU here); the table says"
timeout 120 python3 -m lantern render "$work/cube.usda" -o "$work/seq/f_####.exr" --frames 1:8 \
    --size 640x360 -j 2; echo "exit $?"

echo "== the memory figures, and frames too large refused before drawing"
timeout 120 python3 - "$work/cube.usda" <<'PY'
import sys
from lantern.engine import RenderSettings, Session
from lantern.engine.gpu.budget import TooLarge, gib
from lantern.engine.gpu.framegraph import FrameGraph
from lantern.engine.usd.opening import open_stage

with Session(open_stage(sys.argv[1]), RenderSettings(width=1920, height=1080)) as session:
    stats = session.render().stats
    print({k: stats[k] for k in ("gl_renderer", "gpu_device", "gpu_devices", "gpu_memory_total",
                                 "gpu_memory_free", "gpu_memory_source", "target_bytes_allocated")})
    print(f"1920x1080 medium: targets {gib(stats['target_bytes_allocated'])}, "
          f"{gib(stats['gpu_memory_free'] or 0)} free of {gib(stats['gpu_memory_total'] or 0)}")

    def drew(self, frame, plan=None):   # never draw these: a frame that fits stops here
        raise RuntimeError(f"fits: would draw {frame.size[0]}x{frame.size[1]}")
    FrameGraph.run = drew
    for size, preset in (((16384, 16384), "ultra"), ((16384, 16384), "high"),
                         ((16384, 16384), "medium"), ((8192, 8192), "ultra")):
        session.configure(width=size[0], height=size[1], preset=preset)
        try:
            session.render()
        except TooLarge as error:
            print(f"refused: {error}")
        except RuntimeError as error:
            print(f"{size[0]}x{size[1]} {preset}: {error}")
PY
echo "== done"
rm -rf "$work"
