"""Meshes and objects on the GPU, and how they are drawn: many objects cost little.
Meshes live in a static and a dynamic vertex store (stores.py), each object's matrices
in the object table (objects.py), Points prims apart (points.py).

Drawing: every (object, material range) is one command, prepared in numpy when the
set of objects changes. A view then culls objects against the frustum and orders the
visible commands by pipeline state (material, culling), then front to back, ties by
prim path so any session draws in the same order as a fresh one.
  GL 4.3 path     all commands live in a GPU buffer, uploaded when objects are added
                  or removed; a view uploads only the order of the visible ones (4
                  bytes each: 4 KB for 1,000 objects, against 20 KB for the commands
                  themselves), a compute shader gathers them into the indirect buffer,
                  and each state batch is one glMultiDrawElementsIndirect. The object
                  id reaches the shader as an instanced attribute read at the
                  command's baseInstance.
  GL 3.3 path     one glDrawElements per command with the object id as a uniform.
Shadow casters draw every object once (all of its ranges, one command) from a
buffer made with the commands, but for ranges of see-through materials (cut-outs,
blended), whose casters test their opacity: those are listed apart (alpha_casters).
What 1,000 separate objects cost against one merged mesh: docs/status.md."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...core.transforms import transform_aabbs
from .objects import ObjectTable
from .points import PointClouds
from .programs import set_uniform
from .stores import VERTEX_BYTES, Slot, VertexStore

COMMAND_UINTS = 5            # DrawElementsIndirectCommand


@dataclass
class DrawObject:
    """A Mesh prim on the GPU: its object id, where its triangles are, their state. A
    PointInstancer's batch is one DrawObject of n instances with consecutive ids from
    `oid`: its `local` box is then the union of the instances' world boxes and `world`
    the identity."""
    oid: int
    path: str
    mesh_key: tuple
    skinned: bool
    ranges: list                 # [(material name, first index (absolute), count)]
    cull: bool                   # back faces culled
    mirrored: bool               # negative determinant: clockwise is front
    local: tuple                 # (lo, hi) of the vertices in the space it is drawn in
    world: np.ndarray = field(default_factory=lambda: np.eye(4))
    n: int = 1                   # instances drawn (consecutive object ids)


@dataclass
class Batch:
    """Consecutive commands drawn with one pipeline state."""
    store: VertexStore
    material: str
    cull: bool
    mirrored: bool
    first: int                   # position in the view's command order
    count: int
    instances: int = 0           # PointInstancer instances among them


class Geometry:
    """All meshes and objects of a session on the GPU, and their draw commands."""

    def __init__(self, ctx, uploads, programs, features):
        self.ctx, self.uploads, self.programs = ctx, uploads, programs
        self.multi_draw = features.multi_draw
        self.static = VertexStore(ctx, uploads, "static")
        self.dynamic = None                      # made for the first skinned mesh
        self.objects = ObjectTable(ctx, uploads)
        self.points = PointClouds(ctx, uploads, self.objects)   # Points prims
        self.meshes = {}                         # mesh key -> (store, Slot)
        self._tessellated = {}                   # mesh key -> its triangles' ranges
        self._cages = {}                         # skinned patch mesh key -> deformed cage
        self.draws = {}                          # instance path -> DrawObject
        self._worlds = {}                        # instanced paths -> (n, 4, 4) worlds
        self.moved = []                          # world boxes that changed this frame
        self._ids = None                         # object-id attribute buffer (multi-draw)
        self._stale()
        self._casters = {}                       # store name -> (draws, commands, buffer)
        self._see_through = frozenset()          # materials whose casters test opacity
        self._alpha_casters = []                 # their ranges (alpha_casters)
        self._static_boxes = None                # world boxes while nothing moves
        self._gathered = None                    # the order in the indirect buffer
        self._all = self._indirect = self._order = None

    # --- keeping up with the scene ----------------------------------------------------
    def update(self, scene, changes, cull_backfaces: bool) -> int:
        """Uploads what `changes` says the scene replaced; returns how many meshes
        went up."""
        self.moved = []
        for path in changes.dropped_instances:
            if path not in scene.instances:
                self._drop(path)
        for key in changes.dropped_meshes:
            self._free_mesh(key)
        uploaded = 0
        for key in changes.meshes:
            if key in scene.meshes:
                self._upload_mesh(scene.meshes[key])
                uploaded += 1
        for path in changes.instances:
            inst = scene.instances.get(path)
            if inst is not None:
                self._place(inst, scene.meshes[inst.mesh_key], cull_backfaces)
        if changes.points:
            self.moved += self.points.update(scene, changes.points)
            self._static_boxes = None
        self.objects.flush()
        return uploaded

    def set_culling(self, scene, cull_backfaces: bool):
        """RenderSettings.cull_backfaces changed: every object's culling state again."""
        for d in self.draws.values():
            mesh = scene.meshes[d.mesh_key]
            cull = _culls(mesh, cull_backfaces)
            if cull != d.cull:
                d.cull = cull
                self._stale()

    def _upload_mesh(self, mesh):
        # Skinned meshes and tessellated patches are written by a pass each frame or
        # view (transform feedback), into the dynamic store; patches' triangles are
        # unshared corners, so their indices count up once.
        gpu_written = mesh.skin is not None or mesh.patches is not None
        old = self.meshes.get(mesh.key)
        if mesh.patches is not None:
            n_v = n_i = mesh.patches.max_vertices
            indices = np.arange(n_v, dtype=np.uint32)
        else:
            n_v, n_i, indices = len(mesh.vertices), len(mesh.indices), mesh.indices
        if old is not None and (old[1].n_vertices, old[1].n_indices) == (n_v, n_i) and \
                (old[0] is self.dynamic) == gpu_written:
            store, slot = old              # same topology size: rewrite in place
        else:
            if old is not None:
                self._free_mesh(mesh.key)
            store = self._dynamic() if gpu_written else self.static
            slot = store.alloc(n_v, n_i)
            self.meshes[mesh.key] = (store, slot)
            self._stale()
        if not gpu_written:
            store.write_vertices(slot, mesh.vertices)
        cage = self._cages.pop(mesh.key, None)
        if cage is not None:
            cage.release()
        if mesh.patches is not None and mesh.skin is not None:
            # A skinned cage: the skinning pass deforms its points here, and the
            # tessellation pass makes its patches from them.
            self._cages[mesh.key] = self.uploads.buffer(
                reserve=len(mesh.vertices) * VERTEX_BYTES, kind="mesh")
        for name, values in mesh.streams.items():   # not deformed: once, skinned or not
            store.write_stream(slot, name, values)
        store.write_indices(slot, indices)
        self._tessellated.pop(mesh.key, None)     # rebuilt patches: drawn once tessellated
        if old is not None:
            for path, d in self.draws.items():   # rebuilt data: same key, maybe new ranges
                if d.mesh_key == mesh.key:
                    d.ranges = self._ranges(mesh, slot)
                    d.local = self._local_box(mesh, self._worlds.get(path))
                    self._stale()

    def _ranges(self, mesh, slot: Slot) -> list:
        """[(material name, first index (absolute), count)] of a mesh's triangles."""
        if mesh.patches is not None:
            return self.tessellated(mesh.key)
        return [(mesh.materials[mi], slot.first_index + first, count)
                for mi, first, count in mesh.ranges]

    def deform_target(self, mesh_key):
        """(buffer, byte offset, vertices) where a skinned mesh's deformed vertices go:
        its place in the dynamic store, or a skinned cage's own buffer."""
        cage = self._cages.get(mesh_key)
        if cage is not None:
            return cage, 0, cage.size // VERTEX_BYTES
        store, slot = self.meshes[mesh_key]
        return store.vbo, slot.first_vertex * VERTEX_BYTES, slot.n_vertices

    def tessellated(self, mesh_key) -> list:
        """A tessellated mesh's ranges as last set (absolute first indices)."""
        return list(self._tessellated.get(mesh_key, ()))

    def set_ranges(self, mesh_key, ranges):
        """A tessellated mesh's triangles as the tessellation pass left them:
        [(material name, first index in the mesh's slot, count)]."""
        store, slot = self.meshes[mesh_key]
        absolute = [(m, slot.first_index + first, count) for m, first, count in ranges]
        self._tessellated[mesh_key] = absolute
        for d in self.draws.values():
            if d.mesh_key == mesh_key and d.ranges != absolute:
                d.ranges = list(absolute)
                self._stale()

    def _free_mesh(self, key):
        entry = self.meshes.pop(key, None)
        self._tessellated.pop(key, None)
        cage = self._cages.pop(key, None)
        if cage is not None:
            cage.release()
        if entry is not None:
            entry[0].free(entry[1])
            self._stale()

    def _dynamic(self) -> VertexStore:
        if self.dynamic is None:
            self.dynamic = VertexStore(self.ctx, self.uploads, "dynamic", 1 << 12, 1 << 13)
        return self.dynamic

    def _place(self, inst, mesh, cull_backfaces):
        d = self.draws.get(inst.path)
        store, slot = self.meshes[inst.mesh_key]
        worlds = inst.worlds
        world = np.eye(4) if worlds is not None else inst.world
        n = 1 if worlds is None else len(worlds)
        first = worlds[0] if worlds is not None else world
        mirrored = bool(np.linalg.det(first[:3, :3]) < 0)
        local = self._local_box(mesh, worlds)
        if d is not None and d.n != n:
            self._drop(inst.path)     # a new number of instances: new consecutive ids
            d = None
        if d is None:
            d = self.draws[inst.path] = DrawObject(
                self.objects.new_ids(n), inst.path, inst.mesh_key, mesh.skin is not None,
                self._ranges(mesh, slot), _culls(mesh, cull_backfaces), mirrored, local, n=n)
            self._stale()
        else:
            self._note_moved(d)
            state = (inst.mesh_key, mirrored, _culls(mesh, cull_backfaces), self._ranges(mesh, slot))
            if state != (d.mesh_key, d.mirrored, d.cull, d.ranges):
                self._stale()             # a new mesh or pipeline state: new commands
            d.mesh_key, d.mirrored, d.cull, d.ranges = state
            d.skinned, d.local = mesh.skin is not None, local
        d.world = world
        if worlds is None:
            self._worlds.pop(inst.path, None)
        else:
            self._worlds[inst.path] = worlds
        self.objects.set(d.oid, worlds if worlds is not None else world, inst.pass_index)
        self._static_boxes = None
        self._note_moved(d)

    @staticmethod
    def _local_box(mesh, worlds):
        """The box a DrawObject is culled by, in the space `world` places: the mesh's
        own, or for instances the union of their world boxes."""
        if worlds is None or mesh.bounds is None:
            return mesh.bounds
        lo, hi = transform_aabbs(np.repeat(mesh.bounds[0][None], len(worlds), 0),
                                 np.repeat(mesh.bounds[1][None], len(worlds), 0), worlds)
        return lo.min(axis=0), hi.max(axis=0)

    def _drop(self, path):
        d = self.draws.pop(path, None)
        self._worlds.pop(path, None)
        if d is not None:
            self._note_moved(d)
            self.objects.free_ids(d.oid, d.n)
            self._stale()

    def _stale(self):
        """Something drawn was added, removed or changed: commands and boxes again."""
        self._commands_stale = True
        self._static_boxes = None

    def _note_moved(self, d):
        if d.local is not None:
            lo, hi = transform_aabbs(d.local[0][None], d.local[1][None], d.world[None])
            self.moved.append((lo[0], hi[0]))

    def note_posed(self, d, box):
        """A skinned object's box this frame (shadows that reach it are stale)."""
        self.moved.append(box)

    # --- bounds -----------------------------------------------------------------------
    def world_boxes(self, local_of=None):
        """(draws, lo (n, 3), hi (n, 3)): every object with a box and its world box
        this frame, in command-rank order. local_of(draw) overrides skinned objects'
        local boxes (as posed this frame); the others are kept until something moves."""
        self.ensure_commands()
        if self._static_boxes is None:
            draws = self._ranked
            if draws:
                lo = np.array([d.local[0] for d in draws])
                hi = np.array([d.local[1] for d in draws])
                wlo, whi = transform_aabbs(lo, hi, np.array([d.world for d in draws]))
            else:
                wlo = whi = np.zeros((0, 3))
            skinned = [i for i, d in enumerate(draws) if d.skinned]
            self._static_boxes = (draws, wlo, whi, skinned)
        draws, wlo, whi, skinned = self._static_boxes
        if local_of is not None and skinned:
            wlo, whi = wlo.copy(), whi.copy()
            lo = np.array([local_of(draws[i])[0] for i in skinned])
            hi = np.array([local_of(draws[i])[1] for i in skinned])
            slo, shi = transform_aabbs(lo, hi, np.array([draws[i].world for i in skinned]))
            wlo[skinned], whi[skinned] = slo, shi
        return draws, wlo, whi

    # --- commands ---------------------------------------------------------------------
    def _build_commands(self):
        """The command arrays of every (object, range), and the casters' (one command
        per object), in numpy; on the GL 4.3 path also in GPU buffers."""
        self._release_commands()
        # Ranked with or without triangles: a tessellated object has none until the
        # tessellation pass, after the view pass has taken every object's box.
        draws = sorted((d for d in self.draws.values() if d.local is not None),
                       key=lambda d: d.path)
        self._ranked = draws
        self._rank = {d.path: i for i, d in enumerate(draws)}
        rows, meta = [], []
        for d in draws:
            for material, first, count in d.ranges:
                rows.append((count, d.n, first, 0, d.oid))
                meta.append((d, material))
        self._cmd = np.array(rows, np.uint32).reshape(-1, COMMAND_UINTS)
        self._cmd_instances = np.array([m[0].n if m[0].path in self._worlds else 0
                                        for m in meta], np.int64)
        # A mirrored object's front faces wind clockwise: the winding is pipeline state
        # (culling, and gl_FrontFacing for two-sided shading), so it splits batches.
        self._cmd_key = [(self.meshes[m[0].mesh_key][0] is self.dynamic, m[1], m[0].cull,
                          m[0].mirrored) for m in meta]
        self._cmd_object = np.array([self._rank[m[0].path] for m in meta], np.int64)
        distinct = sorted(set(self._cmd_key))
        index = {k: i for i, k in enumerate(distinct)}
        self._cmd_batch = np.array([index[k] for k in self._cmd_key], np.int64)
        self._casters = {}
        self._alpha_casters = []
        for store in (self.static, self.dynamic):
            if store is None:
                continue
            sel = [d for d in draws if self.meshes[d.mesh_key][0] is store]
            rows = []
            for d in sel:
                joined = False             # an object's consecutive solid ranges: one command
                for material, first, count in d.ranges:
                    if material in self._see_through:
                        self._alpha_casters.append((store, material, first, count, d.oid, d.n))
                        joined = False
                    elif joined and rows[-1][2] + rows[-1][0] == first:
                        rows[-1][0] += count
                    else:
                        rows.append([count, d.n, first, 0, d.oid])
                        joined = True
            cast = np.array(rows, np.uint32).reshape(-1, COMMAND_UINTS)
            buf = self.uploads.buffer(cast, kind="commands") \
                if self.multi_draw and len(cast) else None
            self._casters[store.name] = (sel, cast, buf)
        if self.multi_draw and len(self._cmd):
            self._upload_commands()
        self._commands_stale = False

    def _release_commands(self):
        for buf in [self._all, self._indirect, self._order] + \
                [entry[2] for entry in self._casters.values()]:
            if buf is not None:
                buf.release()
        self._all = self._indirect = self._order = None
        self._casters = {}

    def _upload_commands(self):
        n = len(self._cmd)
        self._gathered = None
        self._all = self.uploads.buffer(self._cmd, kind="commands")
        self._indirect = self.uploads.buffer(reserve=n * COMMAND_UINTS * 4, kind="commands")
        self._order = self.uploads.buffer(reserve=n * 4, kind="commands")
        capacity = self.objects.capacity
        if self._ids is None or self._ids.size < capacity * 4:
            if self._ids is not None:
                self._ids.release()
                for store in (self.static, self.dynamic):
                    if store is not None:
                        store._drop_vaos()
            self._ids = self.uploads.buffer(np.arange(capacity, dtype=np.int32), kind="objects")

    def ensure_commands(self):
        if self._commands_stale:
            self._build_commands()

    def view_batches(self, boxes, eye, forward, outside):
        """(state batches, objects culled): the commands of the objects a view sees,
        in draw order; on the GL 4.3 path gathered into the indirect buffer.
        boxes: this frame's world_boxes; outside(lo, hi) -> culled mask of boxes."""
        self.ensure_commands()
        if not len(self._cmd):
            return [], 0
        _, lo, hi = boxes                         # rank order
        out = outside(lo, hi)
        visible = ~out
        depth = ((lo + hi) * 0.5 - eye) @ forward
        keys = self._cmd_batch
        sel = np.nonzero(visible[self._cmd_object])[0]
        if not len(sel):
            return [], int(out.sum())
        obj = self._cmd_object[sel]
        order = sel[np.lexsort((obj, depth[obj], keys[sel]))]
        self._view_order = order
        batches, start = [], 0
        bounds = np.flatnonzero(np.diff(keys[order])) + 1
        for end in list(bounds) + [len(order)]:
            dynamic, material, cull, mirrored = self._cmd_key[order[start]]
            store = self.dynamic if dynamic else self.static
            batches.append(Batch(store, material, cull, mirrored, start, end - start,
                                 int(self._cmd_instances[order[start:end]].sum())))
            start = end
        if self.multi_draw and not np.array_equal(order, self._gathered):
            # The same order as the last view leaves the indirect buffer as it is.
            self._gathered = order
            self.uploads.write(self._order, order.astype(np.uint32), kind="commands")
            gather = self.programs.get("gather_commands.comp", compute=True)
            self._all.bind_to_storage_buffer(0)
            self._order.bind_to_storage_buffer(1)
            self._indirect.bind_to_storage_buffer(2)
            set_uniform(gather, "n", len(order))
            gather.run((len(order) + 63) // 64)
            self.ctx.memory_barrier()
        return batches, int(out.sum())

    # --- drawing ----------------------------------------------------------------------
    def draw_batch(self, batch: Batch, prog):
        """Draws a view batch with `prog` (a variant compiled for the path:
        object_defines())."""
        if self.multi_draw:
            batch.store.vao(prog, self._ids).render_indirect(
                self._indirect, self.ctx.TRIANGLES, count=batch.count, first=batch.first)
            return
        vao = batch.store.vao(prog)
        for c in self._view_order[batch.first:batch.first + batch.count]:
            count, n, first, _, oid = self._cmd[c]
            prog["u_object"].value = int(oid)
            vao.render(self.ctx.TRIANGLES, vertices=int(count), first=int(first), instances=int(n))

    def set_see_through(self, materials):
        """Materials whose shadow casters test their opacity (cut-outs, blended): their
        ranges leave the casters' commands and are drawn one by one (alpha_casters)."""
        materials = frozenset(materials)
        if materials != self._see_through:
            self._see_through = materials
            self._stale()

    def alpha_casters(self) -> list:
        """[(store, material, first index, count, first object id, instances)] of
        see-through materials."""
        self.ensure_commands()
        return self._alpha_casters

    def draw_casters(self, prog) -> int:
        """Every object's opaque triangles with `prog`; returns the commands drawn."""
        self.ensure_commands()
        n = 0
        for store in (self.static, self.dynamic):
            if store is None or store.name not in self._casters:
                continue
            _, cast, buf = self._casters[store.name]
            if not len(cast):
                continue
            if self.multi_draw:
                store.vao(prog, self._ids).render_indirect(buf, self.ctx.TRIANGLES,
                                                           count=len(cast))
            else:
                vao = store.vao(prog)
                for count, n, first, _, oid in cast:
                    prog["u_object"].value = int(oid)
                    vao.render(self.ctx.TRIANGLES, vertices=int(count), first=int(first),
                               instances=int(n))
            n += len(cast)
        return n

    def object_defines(self) -> list:
        return ["OBJECT_ATTRIBUTE"] if self.multi_draw else []

    def bind_objects(self, unit):
        self.objects.texture.use(unit)

    def path_of(self, oid: int):
        """The instance path (or Points prim) object id `oid` belongs to, or None."""
        for d in self.draws.values():
            if d.oid <= oid < d.oid + d.n:
                return d.path
        return self.points.path_of(oid)

    def has_casters(self) -> bool:
        return any(d.ranges for d in self.draws.values()) or bool(self.points.clouds)

    def release(self):
        self.points.release()
        self._release_commands()
        if self._ids is not None:
            self._ids.release()
        for cage in self._cages.values():
            cage.release()
        self._cages.clear()
        self.static.release()
        if self.dynamic is not None:
            self.dynamic.release()
        self.objects.release()


def _culls(mesh, cull_backfaces: bool) -> bool:
    """Back faces are culled only where culling was asked for: the mesh's
    lantern:backfaceCulling, or the render setting, on a single-sided mesh."""
    return not mesh.double_sided and (mesh.backface_culling or cull_backfaces)
