"""Cycles and EEVEE renders, configured and timed the same way for every scene.

The time of a render is the wall time of `bpy.ops.render.render()`: Blender syncs the
scene into the engine (geometry, BVH, shaders, images) and renders; writing the image
is not included. Each worker first renders once at 1 sample, untimed, so that one-off
start-up work (kernel loading, EEVEE's shader compilation) is not charged to the
first point of the sweep; that first render's time is reported on its own.

Cycles, for the reference and the sweep alike: CPU, fixed seed (not animated),
adaptive sampling off, denoiser off (unless the denoised curve is asked for), sample
clamps off, light threshold 0, a Blackman-Harris pixel filter of a known width.
`direct` mode sets max bounces 0 (a camera ray's hit is lit by lights and the world,
no further bounce); `full` keeps the scene's own bounce limits."""
from __future__ import annotations

import os
import time

import bpy

from .files import atomic_write
from .modes import MODES


def prepare_output(scene):
    """Float EXR of the raw render: no compositor, no sequencer."""
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.color_mode = "RGBA"
    settings.exr_codec = "ZIP"
    scene.render.use_compositing = False
    scene.render.use_sequencer = False


def configure_cycles(scene, samples, seed, mode, denoise, filter_width):
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = int(samples)
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = bool(denoise)
    if denoise:
        cycles.denoiser = "OPENIMAGEDENOISE"
    cycles.seed = int(seed)
    cycles.use_animated_seed = False
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.light_sampling_threshold = 0.0
    cycles.pixel_filter_type = "BLACKMAN_HARRIS"
    cycles.filter_width = float(filter_width)
    if mode == "direct":
        cycles.max_bounces = 0
    elif mode != "full":
        raise ValueError(f"unknown mode {mode!r}; modes: {', '.join(MODES)}")
    return {"max_bounces": cycles.max_bounces, "diffuse_bounces": cycles.diffuse_bounces,
            "glossy_bounces": cycles.glossy_bounces,
            "transmission_bounces": cycles.transmission_bounces,
            "transparent_max_bounces": cycles.transparent_max_bounces}


def configure_eevee(scene, samples):
    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.taa_render_samples = int(samples)


def render(scene, path=None) -> float:
    """Renders the scene; returns the render call's seconds. With `path`, then writes
    the result as a float EXR (atomically, outside the timing)."""
    start = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - start
    if path is not None:
        result = bpy.data.images["Render Result"]
        atomic_write(path, lambda tmp: result.save_render(filepath=tmp, scene=scene),
                     suffix=os.path.splitext(path)[1])
    return seconds
