"""The GPU state of one Session, on the GL thread: what the stage's records became on
the GPU (geometry, objects, lights, material images, rigs, shadow maps, pooled
targets), brought up to date from each sync's Changes, and the frame graph that
draws it. Everything here is released by `release` (Session.close)."""
from __future__ import annotations

import time

import numpy as np

from .context import Features
from .framegraph import Frame, FrameGraph
from .geometry import Geometry
from .lights import LightTable
from .passes.ambient import AmbientPass
from .passes.gbuffer import GBufferPass
from .passes.lights import LightPass
from .passes.resolve import ResolvePass
from .passes.shadows import ShadowPass
from .passes.skinning import SkinningPass
from .passes.view import ViewPass
from .resources import TargetPool, Uploads
from .stencil import Stencil
from .textures import MaterialTextures

# Every counter a render reports, zero when nothing of the kind happened.
COUNTERS = ("meshes_uploaded", "draw_calls", "culled", "meshes_skinned", "shadow_maps",
            "shadow_maps_rendered", "shadow_passes", "shadow_draws", "lights_drawn",
            "light_volumes", "stencil_marks", "batched_lights")


class Renderer:
    def __init__(self, gl, preset):
        ctx = gl.ctx
        self.ctx = ctx
        self.preset = preset
        self.features = Features.of(gl.version)
        self.uploads = Uploads(ctx)
        self.stencil = Stencil(gl.proc)
        self.pool = TargetPool(ctx, self.stencil)
        programs = gl.programs
        self.geometry = Geometry(ctx, self.uploads, programs, self.features)
        self.lights = LightTable(self.uploads, preset.disk_sides)
        self.textures = MaterialTextures(ctx, self.uploads, preset.anisotropy)
        self.skinning = SkinningPass(ctx, self.uploads, programs, self.geometry, gl.scratch)
        self.shadows = ShadowPass(ctx, self.pool, programs, self.geometry, self.lights, preset)
        self.graph = FrameGraph(ctx, self.pool, [
            self.skinning,
            ViewPass(self.geometry),
            self.shadows,
            GBufferPass(ctx, self.pool, programs, self.geometry, self.textures),
            AmbientPass(ctx, self.pool, programs, self.textures),
            LightPass(ctx, self.pool, programs, self.uploads, self.stencil, self.lights,
                      self.geometry, preset),
            ResolvePass(ctx, self.pool, programs),
        ])
        self._cull_backfaces = None

    def update(self, scene, changes, cull_backfaces: bool) -> int:
        """Uploads what the sync changed; returns the number of meshes uploaded."""
        if self._cull_backfaces is not None and cull_backfaces != self._cull_backfaces:
            self.geometry.set_culling(scene, cull_backfaces)
        self._cull_backfaces = cull_backfaces
        meshes = self.geometry.update(scene, changes, cull_backfaces)
        self.lights.update(scene, changes.lights)
        if changes.materials or changes.dropped_meshes:
            self.textures.prune(scene.materials.values())
        self.skinning.update(scene, changes)
        return meshes

    def render(self, scene, changes, camera, size, transparent, cull_backfaces):
        """(rgba float32 (H, W, 4), stats, timings) of one frame."""
        t0 = time.perf_counter()
        frame = Frame(scene=scene, changes=changes, size=tuple(size), preset=self.preset,
                      transparent=transparent, camera=camera,
                      stats={name: 0 for name in COUNTERS})
        frame.stats["meshes_uploaded"] = self.update(scene, changes, cull_backfaces)
        frame.timings["upload"] = time.perf_counter() - t0
        board = self.graph.run(frame)
        uploaded = self.uploads.take()
        frame.stats["bytes_uploaded"] = int(sum(uploaded.values()))
        frame.stats["bytes_by_kind"] = dict(uploaded)
        frame.stats["gl_path"] = "multi-draw (GL 4.3)" if self.features.multi_draw else \
            "draw per object (GL 3.3)"
        self._restore_state()
        return board["rgba"], frame.stats, frame.timings

    def skinned_points(self, scene, changes) -> dict:
        """{mesh path: (points, normals)} of every skinned mesh at this sync's time,
        world space, one row per mesh point (normals unnormalised, as skinned)."""
        self.update(scene, changes, bool(self._cull_backfaces))
        frame = Frame(scene=scene, changes=changes, size=(1, 1), preset=self.preset)
        board = {}
        if self.skinning.needed(frame):
            self.skinning.execute(frame, board)
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
            m3 = w[:3, :3]
            out[path] = (pts @ m3.T + w[:3, 3],
                         nrm @ (np.linalg.inv(m3).T if abs(np.linalg.det(m3)) > 1e-30 else m3).T)
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
        self.graph.release()
        self.textures.release()
        self.lights.release()
        self.geometry.release()
        self.pool.release_all()
