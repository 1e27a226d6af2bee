"""The skinning pass: each skinned mesh (joints and/or blend shapes) is deformed once
per frame into its place in the dynamic store. The G-buffer and every shadow face then
draw that as plain geometry, so a crowd under three shadowed lights is skinned once a
frame, not once per pass and cube face. A mesh is deformed again only when its pose or
blend-shape weights changed (a view change deforms nothing).

Two forms, one body (shaders/skinning.glsl): a compute shader writes the store
directly (skin.comp; GL 4.3, Frame.compute: every shader core of a GPU runs compute,
only a few of a datacenter GPU's run vertex work), and transform feedback (skin.vert)
is the GL 3.3/4.1 form and RenderSettings(compute=False)'s. Both give the same
vertices (tests/test_skinning_compute.py). A mesh too large for one shader storage
block (GL_MAX_SHADER_STORAGE_BLOCK_SIZE: 128 MiB on llvmpipe, 2 GiB on NVIDIA) takes
transform feedback.

Static inputs go up once per mesh: rest vertices, influences (vertex attributes, or a
per-point texture past 8), blend-shape offsets. Per frame only joint matrices (one
texture per skeleton, whatever number of meshes it drives) and the list of active
blend shapes (a few texels per mesh) go up.

A deformed mesh without authored normals gets its surface's own, as its baked twin
(and Blender) would: a second run over the deformed vertices gathers per point the
area normals of its triangles (SKIN_SURFACE_NORMALS; the triangles per point are
static, engine/skin.py incidence_texels). The compute form reads the deformed vertices
in place; transform feedback reads a copy of them (inside the GPU) as a texture, since
a vertex shader cannot read the buffer it writes. Gathering, not scattering: one point
per triangle corner added by blending cost llvmpipe 4-40x the skinning (point set-up),
a geometry shader as much.

reads: nothing   writes: skinned (this frame's posed boxes, and a readback)"""
from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass

import numpy as np

from ....core.transforms import normal_matrix, transform_aabbs
from ...skin import (active_texels, defines, flat_texels, incidence_texels, joint_texels,
                     local_bounds, shape_texels)
from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from ..stencil import entry_points
from ..stores import VERTEX_BYTES, VERTEX_FORMAT

VARYINGS = ("out_pos", "out_normal", "out_uv", "out_tangent")
TEXELS_PER_VERTEX = VERTEX_BYTES // 16   # the static layout as RGBA32F texels
DEFORMED_TEX_W = 4095             # shaders/skin.vert: a multiple of 3
GROUP, MAX_GROUPS = 64, 65535     # shaders/skin.comp's local size; groups per dimension

GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT = 0x90DF
# After the compute form's writes, before what reads them: the passes' vertex fetch,
# compute reads of the store (the surface-normal run, a skinned cage's patch stencils),
# buffer copies and reads (the store's growth, Posed and skinned_points), and transform
# feedback that may write the same vertices later (a frame with compute off).
VERTEX_ATTRIB_ARRAY_BARRIER_BIT, BUFFER_UPDATE_BARRIER_BIT = 0x1, 0x200
TRANSFORM_FEEDBACK_BARRIER_BIT, SHADER_STORAGE_BARRIER_BIT = 0x800, 0x2000
DEFORMED_BARRIERS = (VERTEX_ATTRIB_ARRAY_BARRIER_BIT | BUFFER_UPDATE_BARRIER_BIT |
                     TRANSFORM_FEEDBACK_BARRIER_BIT | SHADER_STORAGE_BARRIER_BIT)
_SIGS = {"glGetIntegerv": (None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))}


@dataclass
class _Input:
    """One skinned mesh's static inputs on the GPU."""
    rest: object                 # vertex buffer in the static layout
    attributes: object           # in_point, joints, weights
    fmt: tuple                   # ModernGL format and names of `attributes`
    stride: int                  # 4-byte words per vertex in `attributes`
    shapes: object = None        # blend-shape offsets texture
    influences: object = None    # per-point influences texture (past 8)
    active: object = None        # this frame's active blend shapes
    incidence: object = None     # surface normals: each point's triangles
    n_active: int = 0
    vaos: dict = None

    def release(self):
        for obj in [self.rest, self.attributes, self.shapes, self.influences, self.active,
                    self.incidence] + \
                list((self.vaos or {}).values()):
            if obj is not None:
                obj.release()


class Posed:
    """What the skinning pass hands on: each skinned object's local box this frame
    (joint-padded, conservative: culling and shadow fitting), the meshes it deformed this
    frame, and the skinned vertices themselves on request (exact: the default view)."""

    def __init__(self, boxes, read, deformed=frozenset()):
        self.boxes = boxes
        self.deformed = deformed
        self._read = read

    def exact_box(self, draw):
        p = self._read(draw.mesh_key)[:, :3].astype(np.float64)
        return (p.min(axis=0), p.max(axis=0)) if len(p) else draw.local


class SkinningPass(Pass):
    name = "skinning"
    writes = ("skinned",)

    def __init__(self, ctx, uploads, programs, geometry, scratch, proc, compute: bool):
        self.ctx, self.uploads, self.programs = ctx, uploads, programs
        self.geometry, self.scratch = geometry, scratch
        self.inputs = {}               # mesh key -> _Input
        self.joints = {}               # skel key -> texture
        self._fresh = set()            # mesh keys whose output is stale
        self.poses = {}                # mesh key -> times deformed (the ray tracer refits)
        self._scratch = None           # surface normals: (vertex copy, its texture)
        self._align = self._block = None
        if compute:                    # the shader storage binding limits of the context
            value = ctypes.c_int(0)
            entry_points(proc, _SIGS)["glGetIntegerv"](GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT,
                                                       ctypes.byref(value))
            # Whole texels (16 bytes: skin.comp indexes the store by them) at or below a
            # mesh's first vertex, on the binding alignment.
            self._align = math.lcm(max(int(value.value), 1), 16)
            self._block = int(ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"])

    def needed(self, frame):
        return bool(self.inputs)

    def update(self, scene, changes):
        """Inputs for new and rebuilt skinned meshes; joint and blend-shape uploads for
        what this sync posed anew; which meshes to deform."""
        for key in list(self.inputs):
            if key not in scene.meshes or key in changes.meshes:
                self.inputs.pop(key).release()
                self._fresh.discard(key)
                self.poses.pop(key, None)
        for key in changes.meshes:
            mesh = scene.meshes.get(key)
            if mesh is not None and mesh.skin is not None:
                self.inputs[key] = self._upload(mesh)
                self._fresh.add(key)
        live = {m.skin.skel_key for m in scene.meshes.values()
                if m.skin is not None and m.skin.has_joints}
        for key in [k for k in self.joints if k not in live]:
            self.joints.pop(key).release()
        for key in live:
            if key in changes.skeletons or key not in self.joints:
                pose = scene.skeletons[key]
                self.joints[key] = self.uploads.rewrite_float_texture(
                    self.joints.get(key), joint_texels(pose.xforms, pose.dqs), kind="joints")
                self._fresh |= {k for k, m in scene.meshes.items()
                                if k in self.inputs and m.skin.skel_key == key}
        for path in changes.shapes | changes.instances:
            inst = scene.instances.get(path)
            if inst is None or inst.mesh_key not in self.inputs:
                continue
            skin = scene.meshes[inst.mesh_key].skin
            if skin.shape_offsets is None:
                continue
            inp = self.inputs[inst.mesh_key]
            texels, inp.n_active = active_texels(skin, inst.shapes)
            inp.active = self.uploads.rewrite_float_texture(inp.active, texels, kind="shapes")
            self._fresh.add(inst.mesh_key)

    def _upload(self, mesh) -> _Input:
        skin = mesh.skin
        n = len(mesh.vertices)
        cols, fmt, names = [mesh.point_of_vertex.astype(np.int32).reshape(n, 1).view(np.float32)], \
            ["1i"], ["in_point"]
        if skin.joints is not None and skin.point_influences is None:
            for h in range(skin.joints.shape[1] // 4):
                cols += [skin.joints[:, 4 * h:4 * h + 4].astype(np.int32).view(np.float32),
                         skin.weights[:, 4 * h:4 * h + 4].astype(np.float32)]
                fmt += ["4i", "4f"]
                names += [f"in_joints{h}", f"in_weights{h}"]
        attributes = np.ascontiguousarray(np.concatenate(cols, axis=1), np.float32)
        inp = _Input(rest=self.uploads.buffer(mesh.vertices, kind="mesh"),
                     attributes=self.uploads.buffer(attributes, kind="mesh"),
                     fmt=(" ".join(fmt), *names), stride=attributes.shape[1], vaos={})
        if skin.shape_offsets is not None:
            inp.shapes = self.uploads.float_texture(shape_texels(skin), kind="mesh")
        if skin.point_influences is not None:
            inp.influences = self.uploads.float_texture(flat_texels(skin.point_influences),
                                                        kind="mesh")
        if mesh.surface_normals:
            inp.incidence = self.uploads.float_texture(
                flat_texels(incidence_texels(mesh.indices, mesh.point_of_vertex, skin.n_points)),
                kind="mesh")
        return inp

    def execute(self, frame, board):
        scene = frame.scene
        self.scratch.use()   # a surfaceless context draws nothing without a framebuffer
        boxes, deformed = {}, {}
        for path, inst in scene.instances.items():
            key = inst.mesh_key
            inp = self.inputs.get(key)
            if inp is None:
                continue
            mesh = scene.meshes[key]
            skin = mesh.skin
            pose = scene.skeletons.get(skin.skel_key) if skin.has_joints else None
            boxes[path] = local_bounds(skin, pose, inst.shapes, *mesh.bounds)
            if key not in self._fresh or key in deformed:
                continue
            deformed[key] = mesh
            frame.count("meshes_skinned")
            draw = self.geometry.draws.get(path)
            if draw is not None:
                lo, hi = boxes[path]
                self.geometry.note_posed(draw, _world_box(lo, hi, inst.world))
        self._deform(deformed.values(), frame.compute)
        board["skinned"] = Posed(boxes, self.read, frozenset(self._fresh))
        self._fresh.clear()

    def _deform(self, meshes, compute: bool):
        """Deforms `meshes` into their targets: in compute where the frame runs it and
        a mesh fits a storage block, else by transform feedback."""
        dispatched = []
        for mesh in meshes:
            self.poses[mesh.key] = self.poses.get(mesh.key, 0) + 1
            if compute and self._fits(mesh):
                self._skin_compute(mesh)
                dispatched.append(mesh)
            else:
                self._skin_feedback(mesh)
        if not dispatched:
            return
        normals = [m for m in dispatched if m.surface_normals]
        if normals:
            self.ctx.memory_barrier(SHADER_STORAGE_BARRIER_BIT)
            for mesh in normals:
                self._surface_normals_compute(mesh)
        self.ctx.memory_barrier(DEFORMED_BARRIERS)

    def _skin_feedback(self, mesh):
        skin, inp = mesh.skin, self.inputs[mesh.key]
        prog = self.programs.get("skin.vert", None, defines(skin), varyings=VARYINGS)
        self._bind(prog, skin, inp)
        target, offset, n = self.geometry.deform_target(mesh.key)
        self._vao(prog, inp, "rest").transform(target, mode=self.ctx.POINTS, vertices=n,
                                               buffer_offset=offset)
        if mesh.surface_normals:
            store, slot = self.geometry.meshes[mesh.key]
            self._surface_normals(mesh, inp, store, slot)

    def _fits(self, mesh) -> bool:
        """Whether each buffer skin.comp binds for `mesh` fits one storage block."""
        inp = self.inputs[mesh.key]
        _, offset, n = self.geometry.deform_target(mesh.key)
        return max(offset % self._align + n * VERTEX_BYTES, inp.rest.size,
                   inp.attributes.size) <= self._block

    def _skin_compute(self, mesh):
        skin, inp = mesh.skin, self.inputs[mesh.key]
        prog = self.programs.get("skin.comp", None, defines(skin), compute=True)
        self._bind(prog, skin, inp)
        inp.rest.bind_to_storage_buffer(1)
        self._dispatch(prog, mesh, inp)

    def _surface_normals_compute(self, mesh):
        """The deformed vertices' normals made the surface's own, in place (after a
        barrier: they read the positions the skinning run wrote)."""
        inp = self.inputs[mesh.key]
        prog = self.programs.get("skin.comp", None, ["SKIN_SURFACE_NORMALS"], compute=True)
        inp.incidence.use(UNITS["u_incidence"])
        set_uniform(prog, "u_points", int(mesh.skin.n_points))
        self._dispatch(prog, mesh, inp)

    def _dispatch(self, prog, mesh, inp):
        """Runs skin.comp over a mesh's vertices: its target bound from the aligned
        texel at or below its first vertex, the texels between given as u_first."""
        target, offset, n = self.geometry.deform_target(mesh.key)
        base = offset - offset % self._align
        target.bind_to_storage_buffer(0, offset=base, size=offset + n * VERTEX_BYTES - base)
        inp.attributes.bind_to_storage_buffer(2)
        set_uniform(prog, "u_first", (offset - base) // 16)
        set_uniform(prog, "u_vertices", int(n))
        set_uniform(prog, "u_attribute_stride", int(inp.stride))
        groups = -(-n // GROUP)
        across = min(groups, MAX_GROUPS)
        prog.run(across, -(-groups // across))

    def _surface_normals(self, mesh, inp, store, slot):
        """Replaces the deformed vertices' normals by the surface's own: the vertices
        are copied (inside the GPU) into a texture, and a transform feedback of the
        copy writes them back, each normal the normalised sum of the area normals of
        its point's triangles (listed per point in inp.incidence)."""
        ctx = self.ctx
        rows = max(1, -(-slot.n_vertices * TEXELS_PER_VERTEX // DEFORMED_TEX_W))
        self._grow_scratch(rows)
        copy, deformed = self._scratch
        ctx.copy_buffer(copy, store.vbo, size=slot.n_vertices * VERTEX_BYTES,
                        read_offset=slot.first_vertex * VERTEX_BYTES)
        self.uploads.copy_into_texture(deformed, copy, (0, 0, DEFORMED_TEX_W, rows))
        prog = self.programs.get("skin.vert", None, ["SKIN_SURFACE_NORMALS"], varyings=VARYINGS)
        deformed.use(UNITS["u_deformed"])
        inp.incidence.use(UNITS["u_incidence"])
        set_uniform(prog, "u_points", int(mesh.skin.n_points))
        self._vao(prog, inp, "copy").transform(store.vbo, mode=ctx.POINTS, vertices=slot.n_vertices,
                                               buffer_offset=slot.first_vertex * VERTEX_BYTES)

    def _grow_scratch(self, rows):
        """The surface-normal scratch (a vertex copy and its texture), grown to hold
        `rows` rows of the texture."""
        old = self._scratch
        if old is not None and old[1].height >= rows:
            return
        rows = max(rows, old[1].height if old else 1)
        self._release_scratch()
        copy = self.ctx.buffer(reserve=DEFORMED_TEX_W * rows * 16)
        deformed = self.ctx.texture((DEFORMED_TEX_W, rows), 4, dtype="f4")
        deformed.filter = self.ctx.NEAREST, self.ctx.NEAREST
        self._scratch = copy, deformed
        for inp in self.inputs.values():        # VAOs reading the old copy
            for key in [k for k in inp.vaos if k[1] == "copy"]:
                inp.vaos.pop(key).release()

    def _vao(self, prog, inp, source):
        """A mesh's "rest" vertices or their deformed "copy", with its influences."""
        key = (id(prog), source)
        vao = inp.vaos.get(key)
        if vao is None:
            vertices = inp.rest if source == "rest" else self._scratch[0]
            vao = inp.vaos[key] = self.ctx.vertex_array(
                prog, [(vertices, *VERTEX_FORMAT), (inp.attributes, *inp.fmt)], skip_errors=True)
        return vao

    def _bind(self, prog, skin, inp):
        """The rig's textures and uniforms, for skin.vert."""
        if skin.has_joints:
            self.joints[skin.skel_key].use(UNITS["u_joint_xforms"])
            if inp.influences is not None:
                inp.influences.use(UNITS["u_influences"])
            set_uniform(prog, "u_influence_groups", int(skin.joints.shape[1] // 4))
            set_uniform(prog, "u_geom_bind", skin.geom_bind)
            set_uniform(prog, "u_geom_bind_normal", normal_matrix(skin.geom_bind))
        if inp.shapes is not None:
            inp.shapes.use(UNITS["u_shape_offsets"])
            inp.active.use(UNITS["u_shape_active"])
            set_uniform(prog, "u_shape_count", int(inp.n_active))
            set_uniform(prog, "u_shape_points", int(skin.n_points))

    def read(self, mesh_key) -> np.ndarray:
        """A skinned mesh's deformed vertices, (V, 12) float32, as drawn this frame (a
        skinned cage's: its points, before the tessellation pass refines them)."""
        target, offset, n = self.geometry.deform_target(mesh_key)
        data = target.read(size=n * VERTEX_BYTES, offset=offset)
        return np.frombuffer(data, np.float32).reshape(-1, 12)

    def release(self):
        for inp in self.inputs.values():
            inp.release()
        for tex in self.joints.values():
            tex.release()
        self.inputs.clear()
        self.joints.clear()
        self._release_scratch()

    def _release_scratch(self):
        if self._scratch is not None:
            for obj in reversed(self._scratch):
                obj.release()
            self._scratch = None


def _world_box(lo, hi, world):
    wlo, whi = transform_aabbs(np.asarray(lo)[None], np.asarray(hi)[None], world[None])
    return wlo[0], whi[0]
