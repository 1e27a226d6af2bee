"""The tessellation pass (GL 4.3 path): each subdivision surface's Bezier patches
(MeshData.patches) are cut by the GPU's tessellation stages at levels chosen from the
camera's view (shaders/tessellate.tesc: pixels per segment, a cap per mesh), evaluated
on the limit surface (tessellate.tese), and written by transform feedback as triangles
into the mesh's place in the dynamic store. The G-buffer, every shadow map and the
other passes then draw them as plain geometry, as they draw skinned meshes: the
surface is the same in every pass, and tessellated once per view. A mesh is
tessellated again only when the view of it, its patches or the image size changed.

A skinned cage (PatchData.stencils) is skinned first, by the skinning pass, into a
buffer of its own (Geometry.deform_target); whenever that pass deformed it, a compute
shader makes its control points again from the deformed points (shaders/
patch_stencils.comp) and the mesh is tessellated again: subdivision after the
armature, as in Blender.

Each material's patches are one draw, with a query counting the triangles it wrote;
their counts become the mesh's draw ranges (Geometry.set_ranges). Reading the counts
waits for the GPU to finish the pass, once per view that changed them.

ModernGL's transform() takes no patches, so the feedback draw is made with the GL
calls below, through the context's entry points.

reads: view, skinned (optional)   writes: tessellated"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass

import numpy as np

from ..framegraph import Pass
from ..programs import set_uniform
from ..stencil import entry_points
from ..stores import VERTEX_BYTES

VARYINGS = ("out_pos", "out_normal", "out_uv", "out_tangent")
PATCH_VERTICES = 16
# A curved patch edge is cut into pieces that turn by at most this much (and are no
# shorter than a pixel), within the mesh's cap: shading interpolates normals across
# each triangle (shaders/tessellate.tesc).
MAX_TURN_RADIANS = np.radians(5.0)

GL_TRIANGLES, GL_PATCHES, GL_PATCH_VERTICES = 0x0004, 0x000E, 0x8E72
GL_RASTERIZER_DISCARD, GL_TRANSFORM_FEEDBACK_BUFFER = 0x8C89, 0x8C8E
GL_PRIMITIVES_WRITTEN, GL_QUERY_RESULT = 0x8C88, 0x8866
VERTEX_ATTRIB_ARRAY_BARRIER_BIT = 0x1

_u, _i, _p = ctypes.c_uint, ctypes.c_int, ctypes.c_ssize_t
_SIGS = {
    "glUseProgram": (None, _u), "glBindVertexArray": (None, _u),
    "glBindBufferRange": (None, _u, _u, _u, _p, _p),
    "glBindBufferBase": (None, _u, _u, _u),
    "glEnable": (None, _u), "glDisable": (None, _u),
    "glPatchParameteri": (None, _u, _i),
    "glBeginTransformFeedback": (None, _u), "glEndTransformFeedback": (None,),
    "glDrawArrays": (None, _u, _i, _i),
    "glGenQueries": (None, _i, ctypes.POINTER(_u)),
    "glDeleteQueries": (None, _i, ctypes.POINTER(_u)),
    "glBeginQuery": (None, _u, _u), "glEndQuery": (None, _u),
    "glGetQueryObjectuiv": (None, _u, _u, ctypes.POINTER(_u)),
}


@dataclass
class _Patches:
    """One mesh's patches on the GPU, and the view they were last cut for."""
    control: object               # 16 control points per patch, positions
    uv: object                    # 16 Bezier control points of the UVs per patch
    stencils: tuple = ()          # a skinned cage's: row starts, points, weights
    vao: object = None
    cut_for: tuple = None

    def release(self):
        for obj in (self.vao, self.control, self.uv, *self.stencils):
            if obj is not None:
                obj.release()


class TessellationPass(Pass):
    name = "tessellation"
    reads = ("view",)
    optional = ("skinned",)
    writes = ("tessellated",)

    def __init__(self, ctx, uploads, programs, geometry, proc, scratch):
        self.ctx, self.uploads, self.programs, self.geometry = ctx, uploads, programs, geometry
        self.scratch = scratch
        self._gl = entry_points(proc, _SIGS)
        self.meshes = {}              # mesh key -> _Patches

    def needed(self, frame):
        return bool(self.meshes)

    def update(self, scene, changes):
        """Control points of new and rebuilt patch meshes go up once."""
        for key in list(self.meshes):
            if key not in scene.meshes or key in changes.meshes:
                self.meshes.pop(key).release()
        for key in changes.meshes:
            mesh = scene.meshes.get(key)
            if mesh is not None and mesh.patches is not None:
                p = mesh.patches
                uv = self.uploads.buffer(p.uv, kind="mesh")
                if p.stencils is None:
                    self.meshes[key] = _Patches(self.uploads.buffer(p.control, kind="mesh"), uv)
                    continue
                rows, points, weights = p.stencils
                stencils = (self.uploads.buffer(rows.astype(np.int32), kind="mesh"),
                            self.uploads.buffer(points.astype(np.int32), kind="mesh"),
                            self.uploads.buffer(weights.astype(np.float32), kind="mesh"))
                self.meshes[key] = _Patches(
                    self.uploads.buffer(reserve=p.control.nbytes, kind="mesh"), uv, stencils)

    def execute(self, frame, board):
        view = board["view"]
        scene = frame.scene
        prog = self.programs.get("tessellate.vert", None, varyings=VARYINGS,
                                 tessellation=("tessellate.tesc", "tessellate.tese"))
        w, h = frame.output_size or frame.size
        nearest = self._nearest_worlds(scene, view)
        posed = board.get("skinned")
        for key, patches in self.meshes.items():
            mesh = scene.meshes[key]
            if patches.stencils and (patches.cut_for is None or
                                     (posed is not None and key in posed.deformed)):
                self._pose(mesh, patches)
                patches.cut_for = None
            world = nearest.get(key)
            if world is None:
                continue
            rel = np.array(world, np.float64)
            rel[:3, 3] -= view.origin
            mvp = view.cull_view_proj @ rel
            target = float(frame.options.tessellation_px)
            cut_for = (mvp.astype(np.float32).tobytes(), w, h, target)
            if cut_for == patches.cut_for:
                continue
            set_uniform(prog, "u_mvp", mvp)
            set_uniform(prog, "u_half_size", (w / 2.0, h / 2.0))
            set_uniform(prog, "u_target_px", target)
            set_uniform(prog, "u_cap", float(mesh.patches.cap))
            set_uniform(prog, "u_turn", float(MAX_TURN_RADIANS))
            self.geometry.set_ranges(key, self._cut(prog, mesh, patches))
            patches.cut_for = cut_for
            frame.count("meshes_tessellated")
        board["tessellated"] = True

    def _nearest_worlds(self, scene, view) -> dict:
        """{mesh key: the world matrix of its instance nearest the camera}: the one
        whose edges look longest sets the levels for all of them."""
        best = {}
        for inst in scene.instances.values():
            key = inst.mesh_key
            if key not in self.meshes:
                continue
            lo, hi = scene.meshes[key].bounds
            centre = (np.asarray(lo) + np.asarray(hi)) / 2.0
            for world in (inst.worlds if inst.worlds is not None else [inst.world]):
                d = np.linalg.norm(world[:3, :3] @ centre + world[:3, 3] - view.origin)
                if key not in best or d < best[key][0]:
                    best[key] = (d, world)
        return {key: world for key, (_, world) in best.items()}

    def _pose(self, mesh, patches):
        """A skinned cage's control points from its points as skinned this frame."""
        prog = self.programs.get("patch_stencils.comp", compute=True)
        cage, offset, _ = self.geometry.deform_target(mesh.key)
        cage.bind_to_storage_buffer(0, offset=offset)
        for binding, buffer in enumerate(patches.stencils, start=1):
            buffer.bind_to_storage_buffer(binding)
        patches.control.bind_to_storage_buffer(4)
        n = 16 * len(mesh.patches.control)
        set_uniform(prog, "n", n)
        prog.run(group_x=-(-n // 64))
        self.ctx.memory_barrier(VERTEX_ATTRIB_ARRAY_BARRIER_BIT)

    def _cut(self, prog, mesh, patches) -> list:
        """Tessellates `mesh` into its slot; returns its ranges [(material, first, count)]."""
        gl, ctx = self._gl, self.ctx
        store, slot = self.geometry.meshes[mesh.key]
        if patches.vao is None:
            patches.vao = ctx.vertex_array(prog, [(patches.control, "3f", "in_pos"),
                                                  (patches.uv, "2f", "in_uv")])
        ranges = mesh.patches.ranges
        queries = (_u * len(ranges))()
        gl["glGenQueries"](len(ranges), queries)
        self.scratch.use()     # a surfaceless context draws nothing without a framebuffer
        gl["glUseProgram"](prog.glo)
        gl["glBindVertexArray"](patches.vao.glo)
        gl["glPatchParameteri"](GL_PATCH_VERTICES, PATCH_VERTICES)
        gl["glBindBufferRange"](GL_TRANSFORM_FEEDBACK_BUFFER, 0, store.vbo.glo,
                                slot.first_vertex * VERTEX_BYTES, slot.n_vertices * VERTEX_BYTES)
        gl["glEnable"](GL_RASTERIZER_DISCARD)
        gl["glBeginTransformFeedback"](GL_TRIANGLES)
        for q, (_, first, count) in zip(queries, ranges):
            gl["glBeginQuery"](GL_PRIMITIVES_WRITTEN, q)
            gl["glDrawArrays"](GL_PATCHES, first * PATCH_VERTICES, count * PATCH_VERTICES)
            gl["glEndQuery"](GL_PRIMITIVES_WRITTEN)
        gl["glEndTransformFeedback"]()
        gl["glDisable"](GL_RASTERIZER_DISCARD)
        gl["glBindBufferBase"](GL_TRANSFORM_FEEDBACK_BUFFER, 0, 0)
        gl["glBindVertexArray"](0)
        out, at, written = [], 0, _u()
        for q, (mi, _, _) in zip(queries, ranges):
            gl["glGetQueryObjectuiv"](q, GL_QUERY_RESULT, ctypes.byref(written))
            out.append((mesh.materials[mi], at, 3 * written.value))
            at += 3 * written.value
        gl["glDeleteQueries"](len(ranges), queries)
        return out

    def read(self, mesh_key) -> np.ndarray:
        """A tessellated mesh's triangle corners as last cut, (3T, 12) float32."""
        store, slot = self.geometry.meshes[mesh_key]
        n = sum(count for _, _, count in self.geometry.tessellated(mesh_key))
        data = store.vbo.read(size=n * VERTEX_BYTES, offset=slot.first_vertex * VERTEX_BYTES)
        return np.frombuffer(data, np.float32).reshape(-1, 12)

    def release(self):
        for patches in self.meshes.values():
            patches.release()
        self.meshes.clear()
