"""Session: the renderer that outlives a frame.

    with Session(stage, RenderSettings(width=320, height=180)) as session:
        result = session.render()                        # the stage's camera at settings.frame
        result = session.render(view_matrix=V, projection_matrix=P, frame=12.0)

A session reads the stage once (engine/usd/stage.py) and keeps its GPU state
(engine/gpu/renderer.py) until `close()`. Each render first brings the scene up to
date, reading only what the stage's edits touched (Usd.Notice) and, at a new time,
only what varies in time; the GL side then uploads only what that replaced, and a
view change reads and uploads nothing but the view's draw order. USD is read on the
caller's thread; every GL call runs on the engine's GL thread."""
from __future__ import annotations

import time
import weakref
from dataclasses import dataclass, field, replace

import numpy as np

from ..core import passes as render_passes
from ..core.presets import preset as find_preset
from .cryptomatte import manifests
from .gpu.context import gl_thread, run_gl
from .gpu.readback import ReadbackRequest
from .gpu.renderer import Renderer
from .usd import camera as usd_camera
from .usd.stage import StageReader
from .settings import RenderSettings
from .view import camera_from_matrices


@dataclass
class RenderResult:
    rgba: np.ndarray             # (H, W, 4) scene-linear, row 0 = top (unless asked
                                 # bottom-up), float32 (or float16: settings.readback)
    # The passes asked for: name -> float32 (H, W, C), row 0 = top, scene-linear.
    passes: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    # Seconds: load (the scene read), upload, per pass (CPU), programs (of the passes'
    # time, making programs), readback, total; a session's first render adds context
    # and setup (the GL context and the GPU state, before the render's total).
    timings: dict = field(default_factory=dict)
    gpu_timings: dict = field(default_factory=dict)  # per pass that ran: GPU seconds
    stats: dict = field(default_factory=dict)    # prims_read, bytes_uploaded, draw_calls, ...
    # The Cryptomatte mattes among the passes: {matte: {name: id as 8 hex digits}}, the
    # manifest an image's metadata carries (engine/cryptomatte.py).
    cryptomatte: dict = field(default_factory=dict)


class Session:
    def __init__(self, stage, settings: RenderSettings | None = None):
        self.settings = settings = settings or RenderSettings()
        self._preset = find_preset(settings.preset)
        self._passes = render_passes.check(settings.passes)
        self.stage = stage
        self.size = usd_camera.resolution(stage, settings.width, settings.height)
        self._camera = None          # (key, Camera) of the stage camera last read
        t0 = time.perf_counter()
        run_gl(lambda gl: None)      # the process's GL context, made by its first job
        t1 = time.perf_counter()
        renderer = run_gl(lambda gl: Renderer(gl, self._preset, settings.srgb_filtering))
        self._renderer = renderer
        self._reader = StageReader(stage, tessellate=renderer.features.tessellation and
                                   settings.tessellation_px > 0)
        # What this session's first render reports besides its own work: the GL
        # context (zero when the process had one) and the GPU state's set-up.
        self._opening = {"context": t1 - t0, "setup": time.perf_counter() - t1}
        # A session dropped without close() still frees its GPU state; at exit the
        # process's context goes with the process.
        self._finalizer = weakref.finalize(self, _release, renderer, self._reader)
        self._finalizer.atexit = False

    def configure(self, **fields):
        """Changes settings for the renders that follow (size, preset, transparent,
        passes, camera, ...), keeping the session's state: a new preset reads and
        uploads nothing again (Renderer.set_preset)."""
        new = replace(self.settings, **fields)
        preset = find_preset(new.preset)
        passes = render_passes.check(new.passes)
        if preset is not self._preset:
            run_gl(lambda gl: self._renderer.set_preset(preset))
            self._preset = preset
        self._passes = passes
        if (new.width, new.height) != (self.settings.width, self.settings.height):
            self.size = usd_camera.resolution(self.stage, new.width, new.height)
        if new.camera != self.settings.camera:
            self._camera = None
        self.settings = new

    @property
    def scene(self):
        """The scene records as of the last render (engine/scene.py), for tools and
        tests; the session owns them."""
        return self._reader.scene

    # --- rendering -------------------------------------------------------------------
    def render(self, view_matrix=None, projection_matrix=None, frame=None, out=None,
               bottom_up=False) -> RenderResult:
        """The stage at `frame` (None: settings.frame, else the stage's start) from the
        given view (None: settings' view, else the stage's camera, else the default
        view framing what is drawn). `out`: a writable buffer of H * W * 4 values of
        the readback format that the image is read into (result.rgba is a view of it);
        `bottom_up`: rows in GL's order (Blender's), not top first."""
        self._check_open()
        t0 = time.perf_counter()
        request = ReadbackRequest(self.settings.readback, top_down=not bottom_up, out=out)
        frame_state = self._submit(view_matrix, projection_matrix, frame, request, t0)
        return self._finish(frame_state, t0)

    def render_frames(self, frames, view_matrix=None, projection_matrix=None):
        """Renders `frames` in order, yielding (frame, RenderResult or the error that
        frame raised). Pipelined: frame N+1 is read from the stage and drawn while
        frame N's pixels are copied behind a fence, one frame of latency
        (stats["readback_latency_frames"]); the images equal render()'s."""
        self._check_open()
        pending = None
        try:
            for when in frames:
                t0 = time.perf_counter()
                request = ReadbackRequest(self.settings.readback, queued=True)
                try:
                    submitted = (when, self._submit(view_matrix, projection_matrix, when,
                                                    request, t0), t0)
                except (ValueError, RuntimeError, OSError) as error:
                    submitted = (when, error, t0)
                done, pending = pending, submitted
                if done is not None:
                    yield self._finish_queued(*done, latest=False)
            done, pending = pending, None
            if done is not None:
                yield self._finish_queued(*done, latest=True)
        finally:
            if pending is not None and not isinstance(pending[1], Exception):
                # Stopped early (an interrupt, or the caller broke off): the queued
                # frame's fence and buffer are freed for the next render.
                run_gl(lambda gl: self._renderer.finish(pending[1]))

    def _finish_queued(self, when, state, t0, latest: bool):
        if isinstance(state, Exception):
            return when, state
        result = self._finish(state, t0)
        result.stats["readback_latency_frames"] = 0 if latest else 1
        if result.stats["nonfinite_pixels"] and not latest:
            # The object ids that name the bad pixels must be drawn with this frame's
            # geometry, which the next frame has replaced: draw this frame again.
            again = self.render(frame=when)
            result.warnings = again.warnings
        return when, result

    def _submit(self, view_matrix, projection_matrix, frame, request, t0):
        when = self._frame(frame)
        changes = self._reader.sync(when)
        if self._reader.settings_changed:
            self._reader.settings_changed = False
            self.size = usd_camera.resolution(self.stage, self.settings.width, self.settings.height)
            self._camera = None
        camera, read = self._view(view_matrix, projection_matrix, when, changes)
        t_load = time.perf_counter() - t0
        scene, size, s = self._reader.scene, self.size, self.settings
        submitted = run_gl(lambda gl: self._renderer.submit(
            scene, changes, camera, size, s.transparent, s.cull_backfaces, self._passes, s,
            request))
        submitted.stats["prims_read"] = changes.prims_read + read
        submitted.timings["load"] = t_load
        return submitted

    def _finish(self, submitted, t0) -> RenderResult:
        view = (submitted.board or {}).get("view")
        rgba, aovs, stats, timings, gpu = run_gl(lambda gl: self._renderer.finish(submitted))
        timings["total"] = time.perf_counter() - t0
        # CPU work of the frame, outside the wait for the GPU's pixels.
        stats["cpu_seconds"] = max(timings["total"] - timings.get("readback", 0.0), 0.0)
        if self._opening:
            timings.update(self._opening)
            self._opening = None
        blank = nothing_on_screen(self._reader.gprims(), stats, view)
        return RenderResult(rgba=rgba, passes=aovs,
                            warnings=self._reader.scene.warning_list() +
                            self._renderer.warnings() + ([blank] if blank else []),
                            timings=timings, gpu_timings=gpu, stats=stats,
                            cryptomatte=manifests(self._reader.scene, self._passes))

    def programs_pending(self) -> int:
        """Programs a viewport's frames wait for (settings.background_compile): render
        again once this is 0 to draw the materials as they are."""
        return run_gl(lambda gl: self._renderer.programs_pending())

    def wait_programs(self, timeout: float | None = None) -> bool:
        """Blocks until no program is pending (False when `timeout` passed first)."""
        helper = run_gl(lambda gl: gl.programs.background)
        return True if helper is None else helper.wait(timeout)

    def skinned_points(self, frame: float) -> dict:
        """GPU-deformed geometry read back: {mesh path: (points, normals)}, world space,
        one row per mesh point (normals as drawn), for every mesh with
        a UsdSkel binding, deformed as this session's frames are (settings.compute).
        For tests against UsdSkel."""
        self._check_open()
        changes = self._reader.sync(float(frame))
        scene = self._reader.scene
        return run_gl(lambda gl: self._renderer.skinned_points(scene, changes, self.settings))

    def trace(self, origins, directions, frame=None, **options):
        """Rays (n, 3) traced against the stage's triangles at `frame` (None: as
        render() takes it), skinned meshes posed: (Hits, the Raytracer's instances
        [(instance path, k-th of its worlds)] that Hits.instance indexes, its counts
        and their "seconds": Raytracer.counts and .seconds).
        `options`: Raytracer.trace's (tmin, tmax, any_hit, brute_force). For tests,
        benches and tools; passes use Renderer.tracer."""
        self._check_open()
        changes = self._reader.sync(self._frame(frame))
        scene = self._reader.scene

        def trace(gl):
            hits, tracer = self._renderer.trace(scene, changes, self.settings, origins,
                                                directions, **options)
            return hits, list(tracer.instances), {**tracer.counts, "seconds": dict(tracer.seconds)}
        return run_gl(trace)

    def drop_traced(self):
        """The next render builds the ray tracer's trees and the irradiance field from
        nothing, without reading the stage or uploading meshes again: what a still costs
        when its scene bounces, for a timing that includes them (`lantern compare`'s
        warm renders, as Cycles' time includes its BVH)."""
        self._check_open()
        run_gl(lambda gl: self._renderer.drop_traced())

    def _frame(self, frame):
        if frame is not None:
            return float(frame)
        if self.settings.frame is not None:
            return float(self.settings.frame)
        return usd_camera.default_time(self.stage)

    def _view(self, view_matrix, projection_matrix, when, changes):
        """(Camera or None for the default view, prims read for it)."""
        if view_matrix is None and projection_matrix is None:
            view_matrix, projection_matrix = self.settings.view_matrix, self.settings.projection_matrix
        if view_matrix is not None and projection_matrix is not None:
            return camera_from_matrices(view_matrix, projection_matrix), 0
        settings_warnings = []
        path = self.settings.camera or usd_camera.settings_camera_path(self.stage,
                                                                        settings_warnings)
        warnings = self._reader.scene.warnings
        if settings_warnings:
            warnings[usd_camera.RENDER_SETTINGS] = settings_warnings
        else:
            warnings.pop(usd_camera.RENDER_SETTINGS, None)
        if path is None:
            cameras = self._reader.cameras()
            path = cameras[0] if cameras else None
        if path is None:
            return None, 0
        prim = self.stage.GetPrimAtPath(path)
        if not prim or not usd_camera.is_camera(prim):
            raise ValueError(f"{path}: not a camera prim")
        w, h = self.size
        if self._camera is not None and path not in changes.cameras:
            key, cam, varies = self._camera
            if key[:2] == (path, w / h) and (not varies or key[2] == when):
                return cam, 0
        cam = usd_camera.camera_from_usd(prim, usd_camera.time_code(when), w / h)
        self._camera = ((path, w / h, when), cam, usd_camera.might_vary(prim))
        return cam, 1

    # --- lifetime --------------------------------------------------------------------
    def _check_open(self):
        if not self._finalizer.alive:
            raise RuntimeError("the session is closed")

    def close(self):
        """Releases every GL resource of the session (on the GL thread) and stops
        listening to the stage."""
        self._finalizer()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def nothing_on_screen(gprims: dict, stats: dict, view) -> str | None:
    """The one line a render says when the stage has gprims and none of them put a
    fragment on screen: what was there, what of it is drawn and where, and where the
    camera looked. None when something is on screen, or the stage has no gprim."""
    if not gprims or stats.get("fragments_drawn") or stats.get("transparent_draws") \
            or stats.get("glass_draws"):
        return None
    total = sum(gprims.values())
    kinds = ", ".join(f"{name} {n}" for name, n in gprims.items())
    where = "nothing of them is drawn"
    if view is not None and view.bounds is not None:
        lo, hi = view.bounds
        where = f"what is drawn lies within {_xyz(lo)}..{_xyz(hi)}"
    looked = ""
    if view is not None:
        cam = view.camera
        name = f" {cam.name}" if cam.name else ""
        looked = f"; the camera{name} at {_xyz(cam.position)} looks along {_xyz(cam.forward)}"
    return (f"nothing is on screen: the stage has {total} gprim{'s' * (total != 1)} "
            f"({kinds}); {where}{looked}")


def _xyz(v) -> str:
    return "(" + ", ".join(f"{float(c) + 0.0:.3g}" for c in v) + ")"    # no -0


def _release(renderer, reader):
    reader.close()
    gl_thread().call(lambda gl: renderer.release())
