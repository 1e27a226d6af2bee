"""Meshes and objects of a session on the GPU, kept up with the scene. Meshes live in a
static and a dynamic vertex store (stores.py), each object's matrices in the object
table (objects.py), Points prims apart (points.py); the draw commands that draw the
objects are commands.py's. Many objects cost little: what 1,000 separate objects cost
against one merged mesh is in docs/status.md."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...core.transforms import transform_aabbs
from .commands import DrawCommands
from .objects import ObjectTable
from .points import PointClouds
from .stores import VERTEX_BYTES, Slot, VertexStore


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


class Geometry:
    """All meshes and objects of a session on the GPU, and their draw commands."""

    def __init__(self, ctx, uploads, programs, features):
        self.ctx, self.uploads = ctx, uploads
        self.static = VertexStore(ctx, uploads, "static")
        self.dynamic = None                      # made for the first skinned mesh
        self.objects = ObjectTable(ctx, uploads)
        self.points = PointClouds(ctx, uploads, self.objects)   # Points prims
        self.meshes = {}                         # mesh key -> (store, Slot)
        self._tessellated = {}                   # mesh key -> its triangles' ranges
        self._cages = {}                         # skinned patch mesh key -> deformed cage
        self.draws = {}                          # instance path -> DrawObject
        self.instance_worlds = {}                # instanced paths -> (n, 4, 4) worlds
        self.moved = []                          # world boxes that changed this frame
        self.commands = DrawCommands(ctx, uploads, programs, features, self)
        self._static_boxes = None                # world boxes while nothing moves

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
        # In path order, so objects take the same ids whatever the set's (hash) order:
        # a blended caster's shadow thresholds hash its id (shaders/shadow.frag).
        for path in sorted(changes.instances):
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
        # Rebuilt patches are drawn once tessellated; until then a patch mesh has no
        # triangles, but the tessellation pass cuts them before any pass draws.
        if mesh.patches is not None:
            self._tessellated[mesh.key] = []
        else:
            self._tessellated.pop(mesh.key, None)
        if old is not None:
            for path, d in self.draws.items():   # rebuilt data: same key, maybe new ranges
                if d.mesh_key == mesh.key:
                    d.ranges = self._ranges(mesh, slot)
                    d.local = self._local_box(mesh, self.instance_worlds.get(path))
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
            self.instance_worlds.pop(inst.path, None)
        else:
            self.instance_worlds[inst.path] = worlds
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
        self.instance_worlds.pop(path, None)
        if d is not None:
            self._note_moved(d)
            self.objects.free_ids(d.oid, d.n)
            self._stale()

    def _stale(self):
        """Something drawn was added, removed or changed: commands and boxes again."""
        self.commands.stale = True
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
        self.commands.ensure()
        if self._static_boxes is None or self._static_boxes[0] is not self.commands.ranked:
            draws = self.commands.ranked
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

    def bind_objects(self, unit):
        self.objects.texture.use(unit)

    def path_of(self, oid: int):
        """The instance path (or Points prim) object id `oid` belongs to, or None."""
        for d in self.draws.values():
            if d.oid <= oid < d.oid + d.n:
                return d.path
        return self.points.path_of(oid)

    def has_casters(self) -> bool:
        """Whether anything casts this frame: an object with triangles, or one whose
        patches the tessellation pass cuts before the shadows (in a session's first
        frame they have none yet)."""
        return any(d.ranges or d.mesh_key in self._tessellated for d in self.draws.values()) \
            or bool(self.points.clouds)

    def release(self):
        self.points.release()
        self.commands.release()
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
