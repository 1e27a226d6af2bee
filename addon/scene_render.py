"""F12, animation frames and material previews, through the engine host (no `gpu`
and no bpy.types here, so every step is testable in background mode).

Each render exports the render depsgraph whole, into the mirror of a stage the host
keeps per scene and view layer (addon/live.py StillScene): only the difference from
the previous render travels, and the host's Session reads again only that, so the
frames of an animation share one Session and its GPU state. The frame comes back
through shared memory with the render passes the view layer asks for, and goes into
the render result with foreach_set, straight from the shared pixels.
"""
from __future__ import annotations

import time
from collections import OrderedDict

import numpy as np

import bpy

from ..core.cryptomatte import metadata
from ..core.passes import COMBINED, PASSES, asked_by
from . import host as host_module
from .live import StillScene

PREVIEW_PRESET = "low"   # material, light and world previews: small and fast
KEPT_STILLS = 4          # F12 scenes (scene, view layer) kept in the host

_stills = OrderedDict()  # scene name -> (host generation, StillScene)


def requested_passes(view_layer) -> list:
    """The render passes this view layer asks for that the engine computes, by the
    engine's names (core/passes.py: one table)."""
    return asked_by(view_layer)


def blender_name(name: str) -> str:
    """A pass's name in this Blender (5.0 renamed IndexOB to Object Index, ...)."""
    return COMBINED if name == COMBINED else PASSES[name].blender_name(bpy.app.version)


def stamp_cryptomatte(engine, layer: str, manifests: dict):
    """The Cryptomatte metadata of the view layer's mattes on the render result, as
    Cycles writes it: Blender's compositor and its EXRs read the manifests there."""
    result = engine.get_result()
    for matte, manifest in manifests.items():
        for field, value in metadata(f"{layer}.{matte}", manifest).items():
            result.stamp_data_add_field(field, value)


def border_rect(render, width, height):
    """(x0, y0, x1, y1) of the border in pixels, y up, as Blender's pipeline computes its
    render rectangle: border fractions times the size, truncated, in single precision."""
    if not render.use_border:
        return 0, 0, width, height
    f32 = np.float32
    return (int(f32(render.border_min_x) * f32(width)), int(f32(render.border_min_y) * f32(height)),
            int(f32(render.border_max_x) * f32(width)), int(f32(render.border_max_y) * f32(height)))


def _still(name, generation) -> StillScene:
    """The mirror of the host's stage for `name`, new when the host is."""
    entry = _stills.pop(name, None)
    if entry is None or entry[0] != generation:
        if entry is not None:
            entry[1].close()
        entry = (generation, StillScene())
    _stills[name] = entry
    while len(_stills) > KEPT_STILLS:
        old, (old_generation, still) = _stills.popitem(last=False)
        still.close()
        host = host_module.get()
        if old_generation == host.generation:
            host.drop(old)
    return entry[1]


def render_frame(engine, depsgraph):
    """RenderEngine.render: F12, one frame of an animation, or a material preview.

    `engine` is the RenderEngine (or anything with its methods). The frame and its
    passes are written into this view layer's result, only inside the border when
    there is one. Esc (test_break) drops the frame at once; errors go to report and
    error_set, never a crash of Blender.
    """
    scene = depsgraph.scene
    layer = depsgraph.view_layer.name
    preview = bool(engine.is_preview)
    width, height = int(engine.resolution_x), int(engine.resolution_y)
    passes = [] if preview else requested_passes(depsgraph.view_layer)
    name = "preview" if preview else f"render:{scene.name_full}:{layer}"
    start = time.perf_counter()

    def stats(info):
        engine.update_stats(f"Lantern | {layer}", info)

    host = host_module.get()
    try:
        if not host.ensure():
            raise host_module.HostError(host.why())
        still = _still(name, host.generation)
        stats("Exporting the scene")
        engine.update_progress(0.0)
        fragment = still.sync(depsgraph)
        if fragment is not None:
            host.edit(name, fragment)
        if engine.test_break():
            return
        stats("Rendering")
        engine.update_progress(0.5)
        request = host.render(name, width=width, height=height,
                              preset=PREVIEW_PRESET if preview else scene.lantern.preset,
                              passes=passes, transparent=scene.render.film_transparent,
                              frame=float(scene.frame_current))
        frame = host.wait(name, request, engine.test_break)
        if frame is None:
            stats("Cancelled")
            return
        x0, y0, x1, y1 = border_rect(scene.render, width, height)
        with host.frame(name) as (frame, views):
            out = engine.begin_result(0, 0, x1 - x0, y1 - y0, layer=layer)
            for pass_name in [COMBINED] + passes:
                # Both bottom row first: the slot is laid out as Blender's result.
                pixels = np.ascontiguousarray(views[pass_name][y0:y1, x0:x1])
                out.layers[0].passes[blender_name(pass_name)].rect.foreach_set(pixels.ravel())
                del pixels
            engine.end_result(out)
            if frame.cryptomatte:
                stamp_cryptomatte(engine, layer, frame.cryptomatte)
    except Exception as error:  # a failed frame is a report, never a crash of Blender
        message = f"Lantern: {error}"
        engine.report({'ERROR'}, message)
        engine.error_set(message)
        return
    if not preview:
        for warning in still.warnings + frame.warnings:
            engine.report({'WARNING'}, f"Lantern: {warning}")
    engine.update_progress(1.0)
    stats(f"Done in {time.perf_counter() - start:.2f} s")


def shutdown():
    """Add-on disable: the host process, its threads and shared memory go."""
    for _, still in _stills.values():
        still.close()
    _stills.clear()
    host_module.shutdown()
