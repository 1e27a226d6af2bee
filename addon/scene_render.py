"""Depsgraph to pixels, shared by F12, material previews and the viewport (no `gpu` and
no bpy.types here, so every step is testable in background mode).

The depsgraph is exported into an in-memory USD stage, the same stage a file export
writes, so F12 and `lantern render` on the exported file give the same pixels.
"""
import threading
import time

import numpy as np

from ..engine import RenderSettings, render_stage
from ..engine import shutdown as engine_shutdown
from ..exporters import stage_from_depsgraph

PREVIEW_PRESET = "low"   # material, light and world previews: small and fast
_POLL_SECONDS = 0.02     # how often a waiting F12 asks Blender whether Esc was pressed

_renders = set()         # render threads still running (a cancelled frame finishes here)
_renders_lock = threading.Lock()


def render_settings(scene, width, height, preview=False, **view):
    """The one mapping from Blender's scene settings to the engine's RenderSettings."""
    return RenderSettings(width=width, height=height, frame=float(scene.frame_current),
                          preset=PREVIEW_PRESET if preview else scene.lantern.preset,
                          transparent=bool(scene.render.film_transparent), **view)


def render_final(depsgraph, width, height):
    """The whole frame, synchronously: (rgba float32 (H, W, 4) scene linear, top row
    first; warnings)."""
    stage, report = stage_from_depsgraph(depsgraph)
    result = render_stage(stage, render_settings(depsgraph.scene, width, height))
    return result.rgba, report.warnings + result.warnings


def border_rect(render, width, height):
    """(x0, y0, x1, y1) of the border in pixels, y up, as Blender's pipeline computes its
    render rectangle: border fractions times the size, truncated, in single precision."""
    if not render.use_border:
        return 0, 0, width, height
    f32 = np.float32
    return (int(f32(render.border_min_x) * f32(width)), int(f32(render.border_min_y) * f32(height)),
            int(f32(render.border_max_x) * f32(width)), int(f32(render.border_max_y) * f32(height)))


def render_frame(engine, depsgraph):
    """RenderEngine.render: F12, one frame of an animation, or a material preview.

    `engine` is the RenderEngine (or anything with its methods). The frame is written
    into the result of this view layer, only inside the border when there is one. Esc
    (test_break) drops the frame at once; errors go to report and error_set.
    """
    scene = depsgraph.scene
    layer = depsgraph.view_layer.name
    preview = bool(engine.is_preview)
    width, height = int(engine.resolution_x), int(engine.resolution_y)
    start = time.perf_counter()

    def stats(info):
        engine.update_stats(f"Lantern | {layer}", info)

    try:
        stats("Exporting the scene")
        engine.update_progress(0.0)
        stage, report = stage_from_depsgraph(depsgraph)
        if engine.test_break():
            return
        stats("Rendering")
        engine.update_progress(0.5)
        result = _render_cancellable(
            stage, render_settings(scene, width, height, preview), engine.test_break)
        if result is None:
            stats("Cancelled")
            return
    except Exception as error:  # a failed frame is a report, never a crash of Blender
        message = f"Lantern: {error}"
        engine.report({'ERROR'}, message)
        engine.error_set(message)
        return
    if not preview:
        for warning in report.warnings + result.warnings:
            engine.report({'WARNING'}, f"Lantern: {warning}")

    x0, y0, x1, y1 = border_rect(scene.render, width, height)
    out = engine.begin_result(0, 0, x1 - x0, y1 - y0, layer=layer)
    # Blender's passes are bottom row first; the engine returns top row first.
    pixels = np.ascontiguousarray(result.rgba[::-1][y0:y1, x0:x1], dtype=np.float32)
    out.layers[0].passes["Combined"].rect.foreach_set(pixels.ravel())
    engine.end_result(out)
    engine.update_progress(1.0)
    stats(f"Done in {time.perf_counter() - start:.2f} s")


def _render_cancellable(stage, settings, test_break):
    """render_stage on a worker thread while this thread polls test_break; None when
    cancelled (the frame in flight finishes on its own and is dropped)."""
    outcome = {}

    def work():
        try:
            outcome["result"] = render_stage(stage, settings)
        except BaseException as error:  # handed back to the waiting thread
            outcome["error"] = error
        finally:
            with _renders_lock:
                _renders.discard(threading.current_thread())

    thread = threading.Thread(target=work, name="lantern-render", daemon=True)
    with _renders_lock:
        _renders.add(thread)
    thread.start()
    while thread.is_alive():
        thread.join(_POLL_SECONDS)
        if thread.is_alive() and test_break():
            return None
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"]


def shutdown():
    """Add-on disable: waits for frames still in flight, then stops the engine's GL
    thread, so disabling or uninstalling leaves no thread behind."""
    with _renders_lock:
        pending = list(_renders)
    for thread in pending:
        thread.join()
    engine_shutdown()


class ViewportSession:
    """Holds the exported stage between redraws.

    A redraw that only moves the view re-renders the stage it has; the scene is
    exported again only when the depsgraph reports changed data.
    """

    def __init__(self):
        self.stage = None
        self.scene = None
        self.exports = 0

    def sync(self, depsgraph):
        changed = any(update.is_updated_geometry or update.is_updated_shading
                      or update.is_updated_transform for update in depsgraph.updates)
        if self.stage is None or changed:
            self.stage, _ = stage_from_depsgraph(depsgraph)
            self.exports += 1
        self.scene = depsgraph.scene

    def draw_pixels(self, view_matrix, window_matrix, width, height):
        """Renders the held stage from the viewport's view, at the region's size."""
        settings = render_settings(self.scene, width, height,
                                   view_matrix=np.array(view_matrix, dtype=np.float64),
                                   projection_matrix=np.array(window_matrix, dtype=np.float64))
        return render_stage(self.stage, settings).rgba
