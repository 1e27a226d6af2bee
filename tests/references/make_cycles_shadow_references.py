"""Renders the box-on-plane shadow scenes with Cycles once; the small EXRs are committed.

Direct light only (max bounces 0), fixed seed, no denoiser, 2048 samples, and a
near-point pixel filter: Lantern samples each pixel at its centre (no anti-aliasing
yet), so Cycles' default 1.5 px filter would measure anti-aliasing, not light and
shadow. Run from the repository root:
    .venv/bin/python tests/references/make_cycles_shadow_references.py
"""
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402

import calibration  # noqa: E402

SAMPLES = 2048


def render(kind):
    scene = calibration.build_box_scene(kind)
    scene.render.engine = 'CYCLES'
    cycles = scene.cycles
    cycles.device = 'CPU'
    cycles.samples = SAMPLES
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = 0
    cycles.max_bounces = 0
    cycles.light_sampling_threshold = 0.0
    cycles.filter_width = 0.01
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.image_settings.exr_codec = 'ZIP'
    scene.render.filepath = str(HERE / f"cycles_box_{kind}.exr")
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    for kind in sys.argv[1:] or calibration.BOX_LIGHTS:
        render(kind)
