"""Renders the reference scenes with Cycles once; the small EXRs are committed.

Direct light only (max bounces 0), fixed seed, no denoiser, many samples, and a
near-point pixel filter: Lantern shades each pixel at its centre (no anti-aliasing
yet), so Cycles' default 1.5 px filter would measure anti-aliasing, not light.
- cycles_<light>.exr: one light over a white plane (calibration.build_scene), 4096 spp;
- cycles_box_<light>.exr: a box on the plane, shadows on (calibration.build_box_scene), 2048 spp.
Run from the repository root (no argument: all of them):
    .venv/bin/python tests/references/make_cycles_references.py [calibration|box] [LIGHT ...]
"""
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402

import calibration  # noqa: E402

SETS = {
    "calibration": (calibration.build_scene, calibration.LIGHTS, "cycles_{}.exr", 4096),
    "box": (calibration.build_box_scene, calibration.BOX_LIGHTS, "cycles_box_{}.exr", 2048),
}


def render(build, kind, filename, samples):
    scene = build(kind)
    scene.render.engine = 'CYCLES'
    cycles = scene.cycles
    cycles.device = 'CPU'
    cycles.samples = samples
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = 0
    cycles.max_bounces = 0
    cycles.light_sampling_threshold = 0.0
    cycles.filter_width = 0.01
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.image_settings.exr_codec = 'ZIP'
    scene.render.filepath = str(HERE / filename.format(kind))
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    chosen = [sys.argv[1]] if len(sys.argv) > 1 else list(SETS)
    for name in chosen:
        build, lights, filename, samples = SETS[name]
        for kind in sys.argv[2:] or lights:
            render(build, kind, filename, samples)
