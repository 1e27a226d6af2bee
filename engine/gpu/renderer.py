"""The GPU state of one Session, on the GL thread: what the stage's records became on
the GPU (geometry, objects, lights, material images, rigs, shadow maps, pooled
targets), brought up to date from each sync's Changes, and the frame graph that
draws it. Everything here is released by `release` (Session.close)."""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ...core.passes import PASSES
from ...core.transforms import normal_matrix
from . import budget
from .context import Features
from .depth import DepthConvention
from .environment import Environment
from ..settings import RenderSettings
from .framegraph import Frame, FrameGraph
from .geometry import Geometry
from .lights import LightTable
from .passes.ambient import AmbientPass
from .passes.antialias import SupersamplePass, centre_samples, filtered
from .passes.ao import AoPass
from .passes.aovs import AovPass
from .passes.cryptomatte import CryptomattePass
from .passes.gbuffer import GBufferPass
from .passes.irradiance import IrradiancePass
from .passes.clustered import ClusteredLightPass
from .passes.light_cull import LightCullPass
from .passes.lights import LightPass
from .passes.near_field import NearFieldPass
from .passes.post import PostPass
from .passes.reflections import ReflectionPass
from .passes.resolve import ResolvePass
from .passes.shadows import ContactRays, ShadowPass
from .passes.skinning import SkinningPass
from .passes.tessellation import TessellationPass
from .passes.glass import GlassPass
from .passes.transparency import TransparencyPass
from .passes.view import ViewPass
from .raytracer import Raytracer
from .readback import Readback, ReadbackRequest, read_mode
from .resources import TargetPool, Uploads
from .stencil import Stencil
from .textures import MaterialTextures


def shadow_ratio(sums: np.ndarray) -> np.ndarray:
    """The Shadow pass from its sums (light with shadows, without): their ratio, grey,
    1 where no light reaches."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(sums[..., 1] > 0, sums[..., 0] / sums[..., 1], 1.0)
    return np.repeat(np.clip(ratio, 0.0, 1.0)[..., None], 3, axis=2).astype(np.float32)


def supersample_factor(frame, size) -> int:
    """The settings' supersampling, else the preset's where an image of `size` stays
    within its sub-pixels (supersample_within). Never lowered to fit the driver: a
    frame too large for it at this factor is refused (budget.check)."""
    o, p = frame.options.supersample, frame.preset
    if o is not None:
        return max(int(o), 1)
    k = max(p.supersample, 1)
    if p.supersample_within and size[0] * size[1] * k * k > p.supersample_within:
        return 1
    return k


# Every counter a render reports, zero when nothing of the kind happened.
COUNTERS = ("meshes_uploaded", "draw_calls", "culled", "meshes_skinned", "meshes_tessellated",
            "shadow_maps", "shadow_maps_rendered", "shadow_passes", "shadow_draws", "lights_drawn",
            "light_volumes", "stencil_marks", "batched_lights", "instances_drawn",
            "points_drawn", "nonfinite_pixels", "transparent_objects", "transparent_draws",
            "glass_objects", "glass_draws",
            "pattern_bytes", "programs_pending", "light_clusters", "light_items",
            "clusters_overflowed", "light_tree_pixels", "light_tree_steps", "light_tree_steps_max",
            "ao_searches", "area_visibility_passes", "field_updates", "field_rays",
            "field_pending", "field_grids")


def _shape(material):
    """The shape of a material's network (None: it has none), which names its variant."""
    return None if material.pattern is None else material.pattern.shape


def _path_name(features) -> str:
    """The GL paths taken, for stats and --debug."""
    draw = "multi-draw (GL 4.3)" if features.multi_draw else "draw per object (GL 3.3)"
    depth = "reversed float depth (GL 4.5)" if features.clip_control else "[-1, 1] depth"
    return f"{draw}, {depth}"


class Renderer:
    def __init__(self, gl, preset, srgb_filtering: str = "encoded"):
        ctx = gl.ctx
        self.ctx = ctx
        self.preset = preset
        self.features = Features.of(gl.version)
        self.gl = gl
        self.gl_info = {**gl.describe(), "gl_path": _path_name(self.features)}
        self.largest_side = budget.largest_side(ctx)
        self._memory = None         # the device's memory as last asked (budget.Memory)
        self.uploads = Uploads(ctx, gl.proc)
        self.stencil = Stencil(gl.proc)
        self.depth = DepthConvention(gl.proc, self.features.clip_control)
        self.pool = TargetPool(ctx, self.stencil)
        programs = self.programs = gl.programs
        self._programs_seen = (programs.compiled, programs.loaded, programs.seconds)
        self.geometry = Geometry(ctx, self.uploads, programs, self.features)
        self.lights = LightTable(self.uploads)
        self.textures = MaterialTextures(ctx, self.uploads, preset.anisotropy, srgb_filtering)
        self.environment = Environment(ctx, self.uploads, programs, gl.proc)
        self.skinning = SkinningPass(ctx, self.uploads, programs, self.geometry, gl.scratch,
                                     gl.proc, self.features.compute)
        self.tessellation = TessellationPass(ctx, self.uploads, programs, self.geometry,
                                             gl.proc, gl.scratch)
        self.shadows = ShadowPass(ctx, self.pool, programs, self.geometry, self.lights,
                                  self.depth, self.textures)
        self.readback = Readback(ctx, programs, gl.proc, compute=self.features.multi_draw,
                                 mode=read_mode(self.features.version))
        self.gl_info["readback_mode"] = self.readback.mode
        self.resolve = ResolvePass(ctx, self.pool, programs, self.geometry, self.depth,
                                   self.readback)
        self.gbuffer = GBufferPass(ctx, self.pool, programs, self.geometry, self.textures,
                                   self.depth)
        self._drawn = {}            # material name -> the record its last frame drew
        self.irradiance = IrradiancePass(ctx, self.uploads, programs, self.lights,
                                         self.environment, self.textures, self.tracer,
                                         self.features.compute)
        self.light_cull = LightCullPass(ctx, programs, self.uploads, self.lights)
        traced = self.tracer if self.features.compute else None   # the passes' rays
        self.contact = ContactRays(self.uploads, traced)
        self.graph = FrameGraph(ctx, self.pool, [
            self.skinning,
            ViewPass(self.geometry, self.depth),
            self.tessellation,
            self.shadows,
            self.gbuffer,
            AovPass(ctx, self.pool, programs),
            self.irradiance,
            AoPass(ctx, self.pool, programs, self.environment),
            AmbientPass(ctx, self.pool, programs, self.environment),
            LightPass(ctx, self.pool, programs, self.uploads, self.stencil, self.lights,
                      self.geometry, self.environment, self.contact),
            self.light_cull,
            ClusteredLightPass(ctx, self.pool, programs, self.lights, self.environment,
                               self.light_cull, self.contact),
            NearFieldPass(ctx, self.pool, programs, self.irradiance, gl.proc),
            ReflectionPass(ctx, self.pool, programs, self.environment, traced, gl.proc),
            GlassPass(ctx, self.pool, programs, self.geometry, self.textures, self.lights,
                      self.environment, self.depth, self.uploads, traced, gl.proc),
            TransparencyPass(ctx, self.pool, programs, self.geometry, self.textures,
                             self.lights, self.environment, self.depth),
            SupersamplePass(ctx, self.pool, programs, self.depth),
            CryptomattePass(ctx, self.pool, programs, self.geometry, self.uploads),
            PostPass(ctx, self.pool, programs),
            self.resolve,
        ], gl.proc)
        self._cull_backfaces = None
        self._raytracer = None      # made by the first ask for rays (tracer)

    def update(self, scene, changes, cull_backfaces: bool) -> int:
        """Uploads what the sync changed; returns the number of meshes uploaded."""
        if self._cull_backfaces is not None and cull_backfaces != self._cull_backfaces:
            self.geometry.set_culling(scene, cull_backfaces)
        self._cull_backfaces = cull_backfaces
        meshes = self.geometry.update(scene, changes, cull_backfaces)
        self.geometry.commands.set_see_through(name for name, m in scene.materials.items()
                                               if m.alpha != "opaque")
        self.lights.update(scene, changes.lights, self.preset.disk_sides)
        if changes.materials or changes.dropped_meshes:
            self.textures.prune(scene.materials.values())
        self.skinning.update(scene, changes)
        self.tessellation.update(scene, changes)
        self.irradiance.note(changes)
        return meshes

    def render(self, scene, changes, camera, size, transparent, cull_backfaces,
               aovs=frozenset(), settings=None, readback=None):
        """(rgba (H, W, 4), {render pass: float32 (H, W, C)}, stats, timings, gpu
        timings) of one frame; `aovs`: the render passes asked for (core/passes.py);
        `settings`: the session's RenderSettings (shading and post options);
        `readback`: how the image reaches host memory (ReadbackRequest). A queued read
        returns rgba None: `finish(frame)` completes it."""
        frame = self.submit(scene, changes, camera, size, transparent, cull_backfaces,
                            aovs, settings, readback)
        return self.finish(frame)

    def submit(self, scene, changes, camera, size, transparent, cull_backfaces,
               aovs=frozenset(), settings=None, readback=None):
        """Draws a frame and starts its read-back; returns the Frame for `finish`."""
        t0 = time.perf_counter()
        frame = Frame(scene=scene, changes=changes, size=tuple(size), preset=self.preset,
                      transparent=transparent, aovs=frozenset(aovs), camera=camera,
                      stats={name: 0 for name in COUNTERS},
                      options=settings or RenderSettings(),
                      readback=readback or ReadbackRequest())
        frame.compute, frame.lighting = self._forms(frame.options)
        frame.stats["forms"] = {"compute": frame.compute, "lighting": frame.lighting}
        frame.stats["meshes_uploaded"] = self.update(scene, changes, cull_backfaces)
        frame.scene = self._drawable(frame)
        frame.timings["upload"] = time.perf_counter() - t0
        k = supersample_factor(frame, size)
        frame.supersample, frame.output_size = k, tuple(size)
        frame.size = (size[0] * k, size[1] * k)
        plan = self.graph.plan(frame)
        self._check_fits(frame, plan)
        self.depth.begin()
        try:
            board = self.graph.run(frame, plan)
        finally:
            self.depth.end()
        self._drawn = dict(frame.scene.materials)
        # Render passes of light were filtered as the image was (SupersamplePass);
        # data (depth, normals, indices), drawn at the supersampled size too, keeps
        # the centre sub-pixel. Cryptomatte's pass ranked its sub-pixels itself, at
        # the image's size.
        board["aovs"] = {name: (a if filtered(name) or PASSES[name].matte else
                                centre_samples(a, k))
                         for name, a in board["aovs"].items()}
        if "Shadow" in board["aovs"]:
            board["aovs"]["Shadow"] = shadow_ratio(board["aovs"]["Shadow"])
        uploaded = self.uploads.take()
        frame.stats["bytes_uploaded"] = int(sum(uploaded.values()))
        frame.stats["bytes_by_kind"] = dict(uploaded)
        self._count_programs(frame)
        frame.stats.update(self.gl_info)
        frame.board = board
        self._restore_state()
        return frame

    def _check_fits(self, frame, plan):
        """Refuses, before any drawing, a frame whose targets the device cannot hold
        (budget.py); puts the device's memory and the targets' bytes in the stats. The
        memory is asked for when the frame needs new targets (a warm frame reuses the
        pool's and reports the last figures)."""
        needed = self.pool.new_bytes(self.graph.held(frame, plan))
        if needed or self._memory is None:
            self._memory = self.gl.memory()
        memory = self._memory
        frame.stats.update(memory.stats(), target_bytes_allocated=needed)
        quality = frame.preset.name if frame.options.supersample is None else ""
        budget.check(frame.output_size, frame.supersample, quality, self.largest_side,
                     needed, memory)

    def _forms(self, options) -> tuple:
        """(compute, lighting) of a frame with these settings on this context. Left to
        Lantern (None), lights are clustered wherever GL 4.3 runs: the light tree keeps
        every light within light_error, where volumes cut each light's tail. The other
        passes take the compute forms on a GPU, and their raster forms on a software
        rasteriser (llvmpipe), which runs both on the same CPU threads: compute gains
        nothing there (docs/gpu.md), and a light with its own shadow map is drawn as
        its volume (passes/lights.py LightPass.drawn)."""
        if options.compute and not self.features.compute:
            raise ValueError(f"compute passes need GL 4.3; this context is GL "
                             f"{self.features.version // 100}.{self.features.version // 10 % 10}")
        compute = self.features.compute and (options.compute if options.compute is not None
                                             else not self.gl.software)
        clustered = self.features.compute and options.compute is not False
        lighting = options.lighting or ("clustered" if clustered else "volumes")
        if lighting == "clustered" and not self.features.compute:
            raise ValueError("clustered lighting needs compute passes (GL 4.3)")
        return compute, lighting

    def _drawable(self, frame):
        """The frame's scene, in which a material whose network changed shape since its
        last frame (or was made or removed), and whose new G-buffer variant is neither made nor stored, is drawn
        as it was (its old record) while the compiler's helper makes the new one
        (engine/gpu/compiler.py; settings.background_compile: the viewport). One with
        nothing old to draw, or whose meshes change layout with it, is compiled in
        place, as is every program without the helper. stats: programs_pending."""
        scene, drawn = frame.scene, self._drawn
        if not frame.options.background_compile:
            return scene
        older = {}
        for name, mat in scene.materials.items():
            old = drawn.get(name)
            if old is None or _shape(old) == _shape(mat) or old.mesh_layout != mat.mesh_layout:
                continue
            new_args = self.gbuffer.frame_program_args(frame, mat)
            if self.programs.ready(*new_args) or \
                    not self.programs.has(*self.gbuffer.frame_program_args(frame, old)):
                continue
            if self.programs.make_later(*new_args):
                older[name] = old
        frame.stats["programs_pending"] = len(older)
        return replace(scene, materials={**scene.materials, **older}) if older else scene

    def programs_pending(self) -> int:
        """Programs the compiler's helper is still making (0 without one)."""
        helper = self.programs.background
        return 0 if helper is None else helper.pending()

    def finish(self, frame):
        """(rgba, aovs, stats, timings, gpu timings) of a submitted frame, its pixels in
        host memory. For a queued frame this waits for its fence, then copies."""
        board = frame.board
        rgba = board["rgba"]
        coverage = board.get("coverage")
        frame.stats["fragments_drawn"] = 0 if coverage is None else int(coverage.samples)
        if rgba is None:
            t0 = time.perf_counter()
            rgba = self.readback.finish(frame.slot)
            frame.timings["readback"] = frame.timings.get("readback", 0.0) + \
                time.perf_counter() - t0
        self.resolve.finish(frame, board["view"], rgba)
        if "clusters" in board:
            self.light_cull.finish(frame, board["clusters"])
        self._restore_state()
        frame.board = None
        return rgba, board["aovs"], frame.stats, frame.timings, self.graph.gpu_times(frame)

    def set_preset(self, preset):
        """Renders that follow use `preset`: what depends on it is rebuilt from what
        the GPU already holds (texture filtering now, the light table's disk polygons
        at the next update, shadow maps at the next frame), nothing is read again."""
        self.preset = preset
        self.textures.set_anisotropy(preset.anisotropy)

    def _count_programs(self, frame):
        """The programs this session made since it last said (its first render counts
        what it made at construction): compiled, or loaded from the persistent cache
        (engine/gpu/program_binaries.py), and the seconds that took, which the passes'
        timings include."""
        p = self.programs
        compiled, loaded, seconds = self._programs_seen
        frame.stats["programs_compiled"] = p.compiled - compiled
        frame.stats["programs_loaded"] = p.loaded - loaded
        frame.timings["programs"] = p.seconds - seconds
        self._programs_seen = (p.compiled, p.loaded, p.seconds)

    def warnings(self) -> list:
        """What the GL side could not use (images it could not read) and the last
        render's non-finite pixels, named by the prims they lie on; what the ray tracer
        leaves out (instances of zero scale); and, once per process, that it draws on
        the CPU (engine/gpu/devices.py)."""
        traced = self._raytracer.warnings if self._raytracer is not None else []
        return self.gl.take_notices() + list(self.textures.failed.values()) + \
            self.resolve.warnings + traced + self.irradiance.warnings

    def tracer(self, scene) -> Raytracer:
        """The session's ray tracer (engine/gpu/raytracer.py), made on the first ask
        and brought up to `scene` as drawn: ask after this frame's skinning pass. Bind
        it (Raytracer.bind) for a compute shader that includes shaders/raytrace.glsl."""
        if not self.features.compute:
            v = self.features.version
            raise ValueError(f"ray tracing needs compute shaders (GL 4.3); this context "
                             f"is GL {v // 100}.{v // 10 % 10}")
        if self._raytracer is None:
            self._raytracer = Raytracer(self.ctx, self.uploads, self.programs,
                                        self.geometry, self.skinning)
        self._raytracer.update(scene)
        return self._raytracer

    def drop_traced(self):
        """Forgets the ray tracer's trees and marks the field stale: the next frame that
        traces builds both from nothing (the geometry's uploads are kept)."""
        if self._raytracer is not None:
            self._raytracer.release()
            self._raytracer = None
        self.irradiance.stale = True

    def _posed(self, scene, changes, settings):
        """Uploads what the sync changed and runs the skinning pass, outside a frame."""
        self.update(scene, changes, bool(self._cull_backfaces))
        frame = Frame(scene=scene, changes=changes, size=(1, 1), preset=self.preset,
                      options=settings or RenderSettings())
        frame.compute, frame.lighting = self._forms(frame.options)
        if self.skinning.needed(frame):
            self.skinning.execute(frame, {})

    def trace(self, scene, changes, settings, origins, directions, **options):
        """Rays traced against the scene at this sync's time (Raytracer.trace's Hits,
        with `options` its), and the tracer that traced them."""
        self._posed(scene, changes, settings)
        tracer = self.tracer(scene)
        hits = tracer.trace(origins, directions, **options)
        self.uploads.take()
        self._restore_state()
        return hits, tracer

    def skinned_points(self, scene, changes, settings=None) -> dict:
        """{mesh path: (points, normals)} of every skinned mesh at this sync's time,
        world space, one row per mesh point (normals as drawn), deformed in the form
        `settings` give a frame (compute or transform feedback)."""
        self._posed(scene, changes, settings)
        out = {}
        for path, inst in scene.instances.items():
            mesh = scene.meshes[inst.mesh_key]
            if mesh.skin is None or inst.mesh_key not in self.skinning.inputs:
                continue
            data = self.skinning.read(inst.mesh_key).astype(np.float64)
            pts = np.zeros((mesh.skin.n_points, 3))
            nrm = np.zeros((mesh.skin.n_points, 3))
            pts[mesh.point_of_vertex] = data[:, :3]
            nrm[mesh.point_of_vertex] = data[:, 3:6]
            w = inst.world
            out[path] = (pts @ w[:3, :3].T + w[:3, 3], nrm @ normal_matrix(w).T)
        self.uploads.take()
        self._restore_state()
        return out

    def _restore_state(self):
        """Leaves the context as a new frame expects it (the state is the context's,
        shared by every session on the GL thread)."""
        ctx = self.ctx
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        ctx.front_face = "ccw"
        ctx.scissor = None

    def release(self):
        if self._raytracer is not None:
            self._raytracer.release()
        self.contact.release()
        self.graph.release()
        self.readback.release()
        self.textures.release()
        self.environment.release()
        self.lights.release()
        self.geometry.release()
        self.pool.release_all()
