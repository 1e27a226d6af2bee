"""Lantern's time, cold and warm: the one place it is measured.

Cold: from the moment the parent process spawned this worker to Lantern's first
image in memory. It holds the process start, the imports (bpy among them), opening
the .blend, the export to an in-memory USD stage, the Session (stage read, GL context,
uploads), shader compilation and the first render: what `lantern render scene.blend`
costs from a shell.
Warm: the median of several renders of one engine.Session after a warm-up render:
what an F12 that keeps its renderer costs per image. Nothing changed, so the Session
reads and uploads nothing; but each timed render builds the ray tracer's trees and the
irradiance field from nothing (Session.drop_traced), as Cycles' time includes its BVH:
no render reuses a field an earlier one made."""
from __future__ import annotations

import dataclasses
import statistics
import time


def point_sampled(pixel_filter: float) -> bool:
    """A filter narrower than half a pixel puts Cycles' samples at the pixel centres,
    where Lantern shades without anti-aliasing: Lantern is then compared with its
    supersampling and FXAA off, as the calibration tests compare it."""
    return pixel_filter < 0.5


def time_lantern(blend, frame, size, preset, transparent, spawned_at, warm_runs,
                 coverage=False, antialias=True, direct=False) -> dict:
    """Renders `blend` with Lantern and times it. spawned_at: time.time() in the parent
    just before it started this process. Returns the image (float RGBA), the times,
    the warnings, and with `coverage` Lantern's coverage (alpha) for foreground masks.
    `direct`: lit directly (bounces 0, as compare's direct mode sets Cycles), else with the
    scene's bounces."""
    from .. import exporters  # Blender's pxr before the engine imports any
    from ..engine import RenderSettings, Session
    from ..engine.bounces import DIRECT
    from .blender_scene import open_scene

    notes = open_scene(blend, frame, size)
    import bpy
    start = time.perf_counter()
    stage, report = exporters.stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    export_seconds = time.perf_counter() - start
    settings = RenderSettings(width=size[0], height=size[1], frame=frame, preset=preset,
                              transparent=transparent, bounces=DIRECT if direct else None,
                              **({} if antialias else {"supersample": 1, "fxaa": False}))
    with Session(stage, settings) as session:
        first = session.render()
        cold_seconds = time.time() - spawned_at
        session.render()  # warm-up
        runs, result = [], first
        for _ in range(max(1, warm_runs)):
            session.drop_traced()
            start = time.perf_counter()
            result = session.render()
            runs.append(time.perf_counter() - start)
    alpha = None
    if coverage:
        with Session(stage, dataclasses.replace(settings, transparent=True)) as session:
            alpha = session.render().rgba[..., 3]
    return {"rgba": result.rgba, "coverage": alpha, "cold_seconds": cold_seconds,
            "warm_seconds": statistics.median(runs), "warm_runs": runs,
            "first_render_seconds": first.timings.get("total"),
            "export_seconds": export_seconds,
            "warnings": list(dict.fromkeys([*notes, *report.warnings, *result.warnings]))}
