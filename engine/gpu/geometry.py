"""Meshes and objects on the GPU, and how they are drawn: many objects cost little.

Storage (seed 003's static and dynamic branches):
  static store    every static mesh's vertices and indices in two large shared
                  buffers, written when the mesh is read and never again (a
                  time-sampled mesh is rewritten in place each frame).
  dynamic store   the same layout, written every frame by the skinning pass (transform
                  feedback); a skinned mesh's indices go up once.
  object table    per object (a Mesh prim drawn), its model and normal matrices: 8
                  RGBA32F texels in one texture, indexed by object id, so moving an
                  object writes 128 bytes. The translation is a double split in two
                  floats (hi in the matrix's fourth column, lo in texel 7): shaders
                  subtract the frame's origin from it (camera-relative rendering,
                  engine/view.py), so the table does not change when the view does.
Indices are absolute in their store, so a draw needs no base vertex (GL 3.3 has none
in ModernGL).

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
buffer made with the commands.

Measured (bench/bench_session.py, 320x180, llvmpipe, 2026-11-22): a view of 1,000
separate cubes takes 1.13-1.23x the time of the same cubes merged into one mesh (e.g.
14.2 against 12.4 ms), 1.28-1.41x on the GL 3.3 path; 4,004 bytes go up per view. The gather costs
0.03 ms; what remains is llvmpipe's own cost per indirect sub-draw, about 3.5 us
(1,000 commands 4.3 ms against 0.8 ms for one), which only merging objects' draws
would remove, at the price of front-to-back order and per-material state."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...core.transforms import transform_aabbs
from ..view import split_double
from .points import PointClouds
from .programs import set_uniform

VERTEX_FORMAT = ("3f 3f 2f 4f", "in_pos", "in_normal", "in_uv", "in_tangent")
VERTEX_BYTES = 48
OBJECT_TEXELS = 8            # model matrix columns (4), normal matrix columns (3), lo translation
OBJECT_TEX_W = 4096          # 512 objects per row: an object never straddles rows
COMMAND_UINTS = 5            # DrawElementsIndirectCommand


class _Arena:
    """First-fit allocation of [start, start + n) ranges in a growable space."""

    def __init__(self, capacity: int):
        self.capacity = capacity
        self.free = [(0, capacity)]

    def alloc(self, n: int):
        """Start of n units, or None when the space must grow first."""
        for i, (start, length) in enumerate(self.free):
            if length >= n:
                self.free[i] = (start + n, length - n)
                if self.free[i][1] == 0:
                    del self.free[i]
                return start
        return None

    def grow(self, capacity: int):
        extra = (self.capacity, capacity - self.capacity)
        self.capacity = capacity
        self._insert(extra)

    def release(self, start: int, n: int):
        if n:
            self._insert((start, n))

    def _insert(self, rng):
        self.free.append(rng)
        self.free.sort()
        merged = []
        for s, n in self.free:
            if merged and merged[-1][0] + merged[-1][1] == s:
                merged[-1] = (merged[-1][0], merged[-1][1] + n)
            else:
                merged.append((s, n))
        self.free = merged


@dataclass
class Slot:
    first_vertex: int
    n_vertices: int
    first_index: int
    n_indices: int


class VertexStore:
    """Vertices (VERTEX_FORMAT) and absolute uint32 indices of many meshes."""

    def __init__(self, ctx, uploads, name: str, vertices: int = 1 << 14, indices: int = 1 << 15):
        self.ctx, self.uploads, self.name = ctx, uploads, name
        self.vertices = _Arena(vertices)
        self.indices = _Arena(indices)
        self.vbo = uploads.buffer(reserve=vertices * VERTEX_BYTES, kind="mesh")
        self.ibo = uploads.buffer(reserve=indices * 4, kind="mesh")
        self.generation = 0           # bumps when the buffers are replaced (VAOs go stale)
        self._vaos = {}

    def alloc(self, n_vertices: int, n_indices: int) -> Slot:
        v = self._alloc(self.vertices, n_vertices, "vbo", VERTEX_BYTES)
        i = self._alloc(self.indices, n_indices, "ibo", 4)
        return Slot(v, n_vertices, i, n_indices)

    def _alloc(self, arena, n, attr, unit):
        start = arena.alloc(n)
        if start is None:
            old = getattr(self, attr)
            capacity = max(arena.capacity * 2, arena.capacity + n)
            new = self.uploads.buffer(reserve=capacity * unit, kind="mesh")
            # A copy inside the GPU, not an upload.
            self.ctx.copy_buffer(new, old, size=arena.capacity * unit)
            old.release()
            setattr(self, attr, new)
            arena.grow(capacity)
            self._drop_vaos()
            start = arena.alloc(n)
        return start

    def free(self, slot: Slot):
        self.vertices.release(slot.first_vertex, slot.n_vertices)
        self.indices.release(slot.first_index, slot.n_indices)

    def write_vertices(self, slot: Slot, vertices: np.ndarray):
        self.uploads.write(self.vbo, np.ascontiguousarray(vertices, np.float32), kind="mesh",
                           offset=slot.first_vertex * VERTEX_BYTES)

    def write_indices(self, slot: Slot, indices: np.ndarray):
        absolute = np.asarray(indices, np.uint32) + np.uint32(slot.first_vertex)
        self.uploads.write(self.ibo, absolute, kind="mesh", offset=slot.first_index * 4)

    def vao(self, prog, ids=None):
        """The VAO of this store for `prog` (with the object-id attribute when `ids`)."""
        key = (id(prog), id(ids))
        vao = self._vaos.get(key)
        if vao is None:
            content = [(self.vbo, *VERTEX_FORMAT)]
            if ids is not None:
                content.append((ids, "1i/i", "in_object"))
            vao = self._vaos[key] = self.ctx.vertex_array(
                prog, content, index_buffer=self.ibo, index_element_size=4, skip_errors=True)
        return vao

    def _drop_vaos(self):
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        self.generation += 1

    def release(self):
        self._drop_vaos()
        self.vbo.release()
        self.ibo.release()


class ObjectTable:
    """Per-object model and normal matrices in one RGBA32F texture (shaders/objects.glsl
    reads them). The instances of an instanced draw take consecutive ids, so one
    command (baseInstance = the first, instanceCount = n) draws them all."""

    def __init__(self, ctx, uploads, rows: int = 1):
        self.ctx, self.uploads = ctx, uploads
        self.data = np.zeros((rows, OBJECT_TEX_W, 4), np.float32)
        self.texture = None
        self._id_space = _Arena(self.capacity)
        self._next = 0                 # one past the highest id ever handed out
        self._dirty = set()

    @property
    def capacity(self) -> int:
        return len(self.data) * (OBJECT_TEX_W // OBJECT_TEXELS)

    def new_ids(self, n: int = 1) -> int:
        """The first of n consecutive free ids."""
        first = self._id_space.alloc(n)
        if first is None:
            per_row = OBJECT_TEX_W // OBJECT_TEXELS
            rows = max(len(self.data) * 2, -(-(self.capacity + n) // per_row))
            grown = np.zeros((rows, OBJECT_TEX_W, 4), np.float32)
            grown[:len(self.data)] = self.data
            self.data = grown
            if self.texture is not None:
                self.texture.release()
                self.texture = None
            self._id_space.grow(self.capacity)
            first = self._id_space.alloc(n)
        self._next = max(self._next, first + n)
        return first

    def free_ids(self, first: int, n: int = 1):
        self._id_space.release(first, n)

    def set(self, first: int, worlds: np.ndarray, pass_index: int = 0):
        """The matrices of objects first, first + 1, ...: (4, 4) or (n, 4, 4), and their
        render-pass index (IndexOB)."""
        worlds = np.asarray(worlds, np.float64).reshape(-1, 4, 4)
        n = len(worlds)
        texels = np.zeros((n, OBJECT_TEXELS, 4), np.float32)
        texels[:, :4] = worlds.transpose(0, 2, 1)          # columns
        hi, lo = split_double(worlds[:, :3, 3])
        texels[:, 3, :3] = hi
        texels[:, 4:7, :3] = normal_matrices(worlds).transpose(0, 2, 1)
        texels[:, 7, :3] = lo
        texels[:, 4, 3] = pass_index                       # render pass IndexOB
        flat = self.data.reshape(-1, 4)
        flat[first * OBJECT_TEXELS:(first + n) * OBJECT_TEXELS] = texels.reshape(-1, 4)
        self._dirty.update(range(first, first + n))

    def flush(self):
        """Uploads the texels of objects set since the last flush (of every object
        when the table was just made or grown), a span per texture row."""
        if self.texture is None:
            h, w = self.data.shape[:2]
            self.texture = self.uploads.texture((w, h), 4, kind="objects", dtype="f4")
            self.texture.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
            self._dirty = set(range(self._next))
        per_row = OBJECT_TEX_W // OBJECT_TEXELS
        rows = {}
        for oid in self._dirty:
            rows.setdefault(oid // per_row, []).append(oid % per_row)
        for row, cols in rows.items():
            x0, x1 = min(cols) * OBJECT_TEXELS, (max(cols) + 1) * OBJECT_TEXELS
            self.uploads.write_texture(self.texture, self.data[row, x0:x1], kind="objects",
                                       viewport=(x0, row, x1 - x0, 1))
        self._dirty.clear()

    def release(self):
        if self.texture is not None:
            self.texture.release()


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
        self.draws = {}                          # instance path -> DrawObject
        self._worlds = {}                        # instanced paths -> (n, 4, 4) worlds
        self.moved = []                          # world boxes that changed this frame
        self._ids = None                         # object-id attribute buffer (multi-draw)
        self._stale()
        self._casters = {}                       # store name -> (draws, commands, buffer)
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
        skinned = mesh.skin is not None
        old = self.meshes.get(mesh.key)
        n_v, n_i = len(mesh.vertices), len(mesh.indices)
        if old is not None and (old[1].n_vertices, old[1].n_indices) == (n_v, n_i) and \
                (old[0] is self.dynamic) == skinned:
            store, slot = old              # same topology size: rewrite in place
        else:
            if old is not None:
                self._free_mesh(mesh.key)
            store = self._dynamic() if skinned else self.static
            slot = store.alloc(n_v, n_i)
            self.meshes[mesh.key] = (store, slot)
            self._stale()
        if not skinned:
            store.write_vertices(slot, mesh.vertices)
        store.write_indices(slot, mesh.indices)
        if old is not None:
            for path, d in self.draws.items():   # rebuilt data: same key, maybe new ranges
                if d.mesh_key == mesh.key:
                    d.ranges = _ranges(mesh, slot)
                    d.local = self._local_box(mesh, self._worlds.get(path))
                    self._stale()

    def _free_mesh(self, key):
        entry = self.meshes.pop(key, None)
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
                _ranges(mesh, slot), _culls(mesh, cull_backfaces), mirrored, local, n=n)
            self._stale()
        else:
            self._note_moved(d)
            state = (inst.mesh_key, mirrored, _culls(mesh, cull_backfaces), _ranges(mesh, slot))
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
        """(draws, lo (n, 3), hi (n, 3)): every object with triangles and its world box
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
        draws = sorted((d for d in self.draws.values() if d.ranges and d.local is not None),
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
        self._cmd_key = [(m[0].skinned, m[1], m[0].cull, m[0].mirrored) for m in meta]
        self._cmd_object = np.array([self._rank[m[0].path] for m in meta], np.int64)
        distinct = sorted(set(self._cmd_key))
        index = {k: i for i, k in enumerate(distinct)}
        self._cmd_batch = np.array([index[k] for k in self._cmd_key], np.int64)
        self._casters = {}
        for store in (self.static, self.dynamic):
            if store is None:
                continue
            sel = [d for d in draws if self.meshes[d.mesh_key][0] is store]
            cast = np.array([(sum(r[2] for r in d.ranges), d.n, d.ranges[0][1], 0, d.oid)
                             for d in sel], np.uint32).reshape(-1, COMMAND_UINTS)
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
            skinned, material, cull, mirrored = self._cmd_key[order[start]]
            store = self.dynamic if skinned else self.static
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

    def draw_casters(self, prog) -> int:
        """Every object's triangles with `prog`; returns the commands drawn."""
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
        self.static.release()
        if self.dynamic is not None:
            self.dynamic.release()
        self.objects.release()


def normal_matrices(worlds) -> np.ndarray:
    """(n, 3, 3) inverse transposes of the worlds' 3x3s (a singular one keeps its own,
    as core.transforms.normal_matrix)."""
    m3 = worlds[:, :3, :3]
    out = m3.copy()
    ok = np.abs(np.linalg.det(m3)) > 1e-30
    if ok.any():
        out[ok] = np.linalg.inv(m3[ok]).transpose(0, 2, 1)
    return out


def _ranges(mesh, slot: Slot) -> list:
    return [(mesh.materials[mi], slot.first_index + first, count)
            for mi, first, count in mesh.ranges]


def _culls(mesh, cull_backfaces: bool) -> bool:
    """Back faces are culled only where culling was asked for: the mesh's
    lantern:backfaceCulling, or the render setting, on a single-sided mesh."""
    return not mesh.double_sided and (mesh.backface_culling or cull_backfaces)
