"""The engine's public entry points: render_stage / render_file.

USD is read on the caller's thread (pxr only); all GL work runs on the engine's own
GL thread (gl_thread.py)."""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdRender

from .camera import camera_from_matrices
from .gl_thread import run_gl
from .renderer import PRESETS, FrameRenderer
from .usd_reader import read_stage

DEFAULT_SIZE = (640, 360)


@dataclass
class RenderSettings:
    width: int | None = None     # None: /Render/Settings resolution if authored, else 640x360
    height: int | None = None
    frame: float | None = None   # None: the stage's startTimeCode if authored, else Default
    preset: str = "medium"       # low | medium | high | ultra
    transparent: bool = False    # alpha = coverage instead of 1
    camera: str | None = None    # a camera prim path; None: /Render/Settings', else the first
    # An explicit view instead of the stage's camera (Blender's viewport): OpenGL
    # world-to-view and projection matrices, column-vector convention.
    view_matrix: np.ndarray | None = None
    projection_matrix: np.ndarray | None = None


@dataclass
class RenderResult:
    rgba: np.ndarray             # float32 (H, W, 4), scene-linear, row 0 = top
    warnings: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)  # load, gbuffer, lights, resolve, total
    stats: dict = field(default_factory=dict)    # meshes_uploaded, draw_calls, ...


def _resolution(stage, settings):
    w, h = settings.width, settings.height
    if w is None or h is None:
        res = None
        prim = stage.GetPrimAtPath("/Render/Settings")
        if prim and prim.IsA(UsdRender.Settings):
            attr = UsdRender.Settings(prim).GetResolutionAttr()
            if attr.HasAuthoredValue():
                res = attr.Get()
        base = (int(res[0]), int(res[1])) if res is not None else DEFAULT_SIZE
        if w is None and h is None:
            w, h = base
        elif w is None:
            w = max(1, round(h * base[0] / base[1]))
        else:
            h = max(1, round(w * base[1] / base[0]))
    if w < 1 or h < 1:
        raise ValueError(f"image size must be positive, got {w}x{h}")
    return int(w), int(h)


def _time_code(stage, settings):
    if settings.frame is not None:
        return Usd.TimeCode(settings.frame)
    if stage.HasAuthoredMetadata("startTimeCode"):
        return Usd.TimeCode(stage.GetStartTimeCode())
    return Usd.TimeCode.Default()


def render_stage(stage: Usd.Stage, settings: RenderSettings | None = None) -> RenderResult:
    settings = settings or RenderSettings()
    if settings.preset not in PRESETS:
        raise ValueError(f"unknown preset {settings.preset!r}; valid presets: "
                         f"{', '.join(PRESETS)}")
    t0 = _time.perf_counter()
    w, h = _resolution(stage, settings)
    view = None
    if settings.view_matrix is not None and settings.projection_matrix is not None:
        view = camera_from_matrices(settings.view_matrix, settings.projection_matrix)
    scene = read_stage(stage, _time_code(stage, settings), w / h, camera=view)
    t_load = _time.perf_counter() - t0

    def job(ctx):
        fr = FrameRenderer(ctx, scene, w, h, settings.preset, settings.transparent)
        rgba, timings = fr.render()
        return rgba, timings, fr.stats

    rgba, timings, stats = run_gl(job)
    timings["load"] = t_load
    timings["total"] = _time.perf_counter() - t0
    return RenderResult(rgba=rgba, warnings=list(scene.warnings), timings=timings, stats=stats)


def render_file(path: str, settings: RenderSettings | None = None) -> RenderResult:
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise OSError(f"cannot open USD file {path}")
    return render_stage(stage, settings)


# --- time: sequences and skinned-geometry readback ------------------------------------

def _frames_of(stage, settings, first, last):
    if last < first:
        raise ValueError(f"empty frame range {first}:{last}")
    return [float(f) for f in np.arange(first, last + 0.5, 1.0)]


def render_sequence(stage: Usd.Stage, first: float, last: float,
                    settings: RenderSettings | None = None):
    """Yields (frame, RenderResult) for frames first..last, reading the stage's static
    data once and keeping one set of GL buffers: per frame only transforms, skeleton
    poses, blend-shape weights, cameras and lights are read and uploaded."""
    from .renderer import GeometryCache
    from .usd_reader import StageCache
    settings = settings or RenderSettings()
    if settings.preset not in PRESETS:
        raise ValueError(f"unknown preset {settings.preset!r}; valid presets: "
                         f"{', '.join(PRESETS)}")
    w, h = _resolution(stage, settings)
    view = None
    if settings.view_matrix is not None and settings.projection_matrix is not None:
        view = camera_from_matrices(settings.view_matrix, settings.projection_matrix)
    cache = StageCache(stage)
    gpu = GeometryCache()
    try:
        for frame in _frames_of(stage, settings, first, last):
            t0 = _time.perf_counter()
            scene = read_stage(stage, Usd.TimeCode(frame), w / h, camera=view, cache=cache)
            t_load = _time.perf_counter() - t0

            def job(ctx, scene=scene):
                fr = FrameRenderer(ctx, scene, w, h, settings.preset, settings.transparent, gpu=gpu)
                rgba, timings = fr.render()
                return rgba, timings, fr.stats

            rgba, timings, stats = run_gl(job)
            timings["load"] = t_load
            timings["total"] = _time.perf_counter() - t0
            yield frame, RenderResult(rgba=rgba, warnings=list(scene.warnings),
                                      timings=timings, stats=stats)
    finally:
        run_gl(lambda ctx: gpu.release())


def skinned_points(stage: Usd.Stage, frame: float, cache=None) -> dict:
    """GPU-deformed geometry read back by transform feedback: {mesh path: (points,
    normals)}, world space, one row per mesh point (normals unnormalised, as
    skinned), for every mesh with a UsdSkel binding. For tests against UsdSkel."""
    from .renderer import GeometryCache
    from .skinning import readback
    from .usd_reader import StageCache
    cache = cache or StageCache(stage)
    scene = read_stage(stage, Usd.TimeCode(frame), 1.0, cache=cache)

    def job(ctx):
        gpu = GeometryCache()
        fr = FrameRenderer(ctx, scene, 1, 1, "low", False, gpu=gpu)
        try:
            return readback(fr)
        finally:
            fr.release()
            gpu.release()
    return run_gl(job)
