"""Draw commands: how the objects of a session's Geometry (geometry.py) are drawn.

Every (object, material range) is one command, prepared in numpy when the set of
objects changes. A view then culls objects against the frustum and orders the
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
A shadow tile draws only the casters whose boxes meet its frustum: runs of them from
that buffer, nothing uploaded.
What 1,000 separate objects cost against one merged mesh: docs/status.md."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .programs import set_uniform
from .stores import VertexStore

COMMAND_UINTS = 5            # DrawElementsIndirectCommand


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


class DrawCommands:
    """The draw commands of a Geometry's objects, rebuilt when it marks them stale."""

    def __init__(self, ctx, uploads, programs, features, geometry):
        self.ctx, self.uploads, self.programs = ctx, uploads, programs
        self.multi_draw = features.multi_draw
        self.geometry = geometry                 # read at each rebuild: draws, meshes, stores
        self.stale = True                        # set by the geometry when a draw changes
        self.ranked = []                         # drawn objects with a box, by prim path
        self._ids = None                         # object-id attribute buffer (multi-draw)
        self._casters = {}                       # store name -> (ranks, commands, buffer)
        self._see_through = frozenset()          # materials whose casters test opacity
        self._alpha_casters = []                 # their ranges (alpha_casters)
        self._gathered = None                    # the order in the indirect buffer
        self._all = self._indirect = self._order = None

    def ensure(self):
        if self.stale:
            self._build()

    def _build(self):
        """The command arrays of every (object, range), and the casters' (one command
        per object), in numpy; on the GL 4.3 path also in GPU buffers."""
        self._release()
        geo = self.geometry
        # Ranked with or without triangles: a tessellated object has none until the
        # tessellation pass, after the view pass has taken every object's box.
        draws = sorted((d for d in geo.draws.values() if d.local is not None),
                       key=lambda d: d.path)
        self.ranked = draws
        rank = {d.path: i for i, d in enumerate(draws)}
        rows, meta = [], []
        for d in draws:
            for material, first, count in d.ranges:
                rows.append((count, d.n, first, 0, d.oid))
                meta.append((d, material))
        self._cmd = np.array(rows, np.uint32).reshape(-1, COMMAND_UINTS)
        self._cmd_instances = np.array([m[0].n if m[0].path in geo.instance_worlds else 0
                                        for m in meta], np.int64)
        # A mirrored object's front faces wind clockwise: the winding is pipeline state
        # (culling, and gl_FrontFacing for two-sided shading), so it splits batches.
        self._cmd_key = [(geo.meshes[m[0].mesh_key][0] is geo.dynamic, m[1], m[0].cull,
                          m[0].mirrored) for m in meta]
        self._cmd_object = np.array([rank[m[0].path] for m in meta], np.int64)
        distinct = sorted(set(self._cmd_key))
        index = {k: i for i, k in enumerate(distinct)}
        self._cmd_batch = np.array([index[k] for k in self._cmd_key], np.int64)
        self._casters = {}
        self._alpha_casters = []
        for store in (geo.static, geo.dynamic):
            if store is None:
                continue
            sel = [d for d in draws if geo.meshes[d.mesh_key][0] is store]
            rows, ranks = [], []
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
                        ranks.append(rank[d.path])
                        joined = True
            cast = np.array(rows, np.uint32).reshape(-1, COMMAND_UINTS)
            buf = self.uploads.buffer(cast, kind="commands") \
                if self.multi_draw and len(cast) else None
            self._casters[store.name] = (np.array(ranks, np.int64), cast, buf)
        if self.multi_draw and len(self._cmd):
            self._upload()
        self.stale = False

    def _release(self):
        for buf in [self._all, self._indirect, self._order] + \
                [entry[2] for entry in self._casters.values()]:
            if buf is not None:
                buf.release()
        self._all = self._indirect = self._order = None
        self._casters = {}

    def _upload(self):
        n = len(self._cmd)
        self._gathered = None
        self._all = self.uploads.buffer(self._cmd, kind="commands")
        self._indirect = self.uploads.buffer(reserve=n * COMMAND_UINTS * 4, kind="commands")
        self._order = self.uploads.buffer(reserve=n * 4, kind="commands")
        capacity = self.geometry.objects.capacity
        if self._ids is None or self._ids.size < capacity * 4:
            if self._ids is not None:
                self._ids.release()
                for store in (self.geometry.static, self.geometry.dynamic):
                    if store is not None:
                        store._drop_vaos()
            self._ids = self.uploads.buffer(np.arange(capacity, dtype=np.int32), kind="objects")

    # --- a view -----------------------------------------------------------------------
    def view_batches(self, boxes, eye, forward, outside):
        """(state batches, objects culled): the commands of the objects a view sees,
        in draw order; on the GL 4.3 path gathered into the indirect buffer.
        boxes: this frame's Geometry.world_boxes; outside(lo, hi) -> culled mask of boxes."""
        self.ensure()
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
            store = self.geometry.dynamic if dynamic else self.geometry.static
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
            self.stale = True

    def alpha_casters(self) -> list:
        """[(store, material, first index, count, first object id, instances)] of
        see-through materials."""
        self.ensure()
        return self._alpha_casters

    def draw_casters(self, prog, seen=None) -> int:
        """The objects' opaque triangles with `prog`; returns the commands drawn.
        seen: None (every object), or a bool per ranked object (world_boxes' order):
        those whose boxes meet the tile's frustum. The others would be clipped whole,
        so the image is the same; a point light's face or a cascade sees few of a
        scene's objects, and llvmpipe shades every vertex of what is drawn."""
        self.ensure()
        n = 0
        for store in (self.geometry.static, self.geometry.dynamic):
            if store is None or store.name not in self._casters:
                continue
            ranks, cast, buf = self._casters[store.name]
            rows = np.arange(len(cast)) if seen is None else np.flatnonzero(seen[ranks])
            if not len(rows):
                continue
            if self.multi_draw:
                vao = store.vao(prog, self._ids)
                # Runs of consecutive commands: one indirect draw each.
                breaks = np.flatnonzero(np.diff(rows) != 1) + 1
                for run in np.split(rows, breaks):
                    vao.render_indirect(buf, self.ctx.TRIANGLES, count=len(run),
                                        first=int(run[0]))
            else:
                vao = store.vao(prog)
                for count, instances, first, _, oid in cast[rows]:
                    prog["u_object"].value = int(oid)
                    vao.render(self.ctx.TRIANGLES, vertices=int(count), first=int(first),
                               instances=int(instances))
            n += len(rows)
        return n

    def object_defines(self) -> list:
        return ["OBJECT_ATTRIBUTE"] if self.multi_draw else []

    def release(self):
        self._release()
        if self._ids is not None:
            self._ids.release()
            self._ids = None
