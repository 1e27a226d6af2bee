"""04_lights.blend at 640x360: Lantern against EEVEE, error against Cycles, in one run.

Lantern's time is the export of the depsgraph into an in-memory stage plus the
render (warm: shaders compiled by a first render, as EEVEE's are by its first).
EEVEE renders at its scene setting (64 samples) and at 1 sample.
"""
import os
import pathlib
import sys
import time

import lantern.exporters  # noqa: F401  (Blender's pxr first)
import bpy
import numpy as np

from lantern.engine import RenderSettings, render_stage
from lantern.exporters import stage_from_depsgraph

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))
from image_metrics import mean_flip, psnr  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parent.parent
SCENE = REPO.parent / "shared" / "corpus" / "blender" / "04_lights.blend"
WIDTH, HEIGHT = 640, 360
OUT = REPO / "out" / "bench"


def _blender_render(engine, samples=None):
    scene = bpy.context.scene
    scene.render.engine = engine
    if engine == 'BLENDER_EEVEE' and samples:
        scene.eevee.taa_render_samples = samples
    if engine == 'CYCLES':
        scene.cycles.samples = samples
        scene.cycles.use_denoising = False
        scene.cycles.seed = 0
        scene.cycles.device = 'CPU'
    path = OUT / f"{engine.lower()}_{samples}.exr"
    scene.render.filepath = str(path)
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - start
    from lantern.engine.image_io import read_exr
    return seconds, read_exr(str(path))


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.open_mainfile(filepath=str(SCENE), load_ui=False)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.film_transparent = False

    settings = RenderSettings(width=WIDTH, height=HEIGHT, frame=float(scene.frame_current))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    stage, _ = stage_from_depsgraph(depsgraph)
    render_stage(stage, settings)  # compiles shaders, creates the GL context
    runs = []
    for _ in range(5):
        start = time.perf_counter()
        stage, _ = stage_from_depsgraph(depsgraph)
        result = render_stage(stage, settings)
        runs.append(time.perf_counter() - start)
    lantern_s = float(np.median(runs))
    lantern = result.rgba

    eevee_s, eevee = _blender_render('BLENDER_EEVEE', 64)
    eevee1_s, eevee1 = _blender_render('BLENDER_EEVEE', 1)
    cycles_samples = int(os.environ.get("LANTERN_BENCH_CYCLES_SAMPLES", "256"))
    cycles_s, cycles = _blender_render('CYCLES', cycles_samples)

    print(f"04_lights.blend at {WIDTH}x{HEIGHT} ({time.strftime('%Y-%m-%d')}, "
          f"{os.cpu_count()} cores, llvmpipe for GL)")
    print(f"{'renderer':<22}{'seconds':>10}{'vs Lantern':>12}{'PSNR dB':>10}{'FLIP':>8}   (error vs Cycles {cycles_samples} spp)")
    rows = [("Lantern (export+render)", lantern_s, lantern),
            ("EEVEE 64 samples", eevee_s, eevee),
            ("EEVEE 1 sample", eevee1_s, eevee1)]
    for name, seconds, image in rows:
        print(f"{name:<22}{seconds:>10.3f}{seconds / lantern_s:>11.1f}x"
              f"{psnr(image, cycles):>10.2f}{mean_flip(image, cycles):>8.4f}")
    print(f"{'Cycles (reference)':<22}{cycles_s:>10.3f}{cycles_s / lantern_s:>11.1f}x")
    print(f"Lantern / EEVEE(64) time ratio: {lantern_s / eevee_s:.4f}")
    print(f"Lantern / EEVEE(1)  time ratio: {lantern_s / eevee1_s:.4f}")
    print(f"Lantern render passes, GPU (s): " + ", ".join(f"{k} {v:.4f}" for k, v in result.gpu_timings.items()))


if __name__ == "__main__":
    main()
