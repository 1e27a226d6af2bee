"""The ray tracer's data on the GPU: the scene's triangles, a bottom-level BVH per mesh
in its object space, and a top-level BVH over the instances placed in the world
(engine/bvh.py builds them; shaders/raytrace.glsl walks them in compute shaders).

Made only when something asks for rays (Renderer.tracer), then kept up with the
scene by `update`, which builds only what changed:
- a mesh's tree is built when its record is new (the reader replaces a record whose
  prim changed), and refitted when the skinning pass deformed it again (its deformed
  vertices read from the dynamic store: SkinningPass.read);
- the instances of one mesh (Mesh prims sharing its data, a PointInstancer's
  instances) share its tree; the top tree is built again when an instance moved, came
  or went, or a mesh's box changed.

Triangles of a subdivision surface tessellated on the GPU are its patches' corners,
two a patch (the limit surface at the cage refined `levels` times, engine/scene.py
PatchData): the tessellation the passes draw depends on the view, a tree must not.

Arrays, one after another in one RGBA32UI texture of WIDTH vec4 a line (RtData: llvmpipe
serves a walk's lane-divergent reads faster from a texture than from a storage buffer,
shaders/raytrace.glsl), its first vec4 where each starts; shaders/raytrace.glsl reads
them, `bind` binds the texture:
  nodes      every bottom tree, NODE_FLOATS floats a node, miss links absolute
  triangles  3 vec4 each: corners in object space; v0.w the material (an index into
             `materials`), v1.w the triangle's index in its mesh, as int bits
  instances  INSTANCE_VEC4 vec4 each: world to object rows, object to world rows,
             (root node, first triangle, triangles, object id) as int bits
  top        the top tree (its root's miss link 0 when there is no instance)"""
from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass

import numpy as np

from ...core.transforms import SINGULAR, affine_inverse, cross, transform_aabbs
from .. import bvh
from .programs import UNITS, set_uniform

SECTIONS = ("nodes", "triangles", "instances", "top")   # rt_bases()' x, y, z, w
WIDTH = 4096                      # shaders/raytrace.glsl RT_WIDTH_BITS
INSTANCE_VEC4 = 7
FAR = 3.0e38                      # shaders/raytrace.glsl RT_FAR
GROUP, MAX_GROUPS = 64, 65535     # shaders/trace.comp's local size; groups per dimension
SHADER_STORAGE_BARRIER_BIT, BUFFER_UPDATE_BARRIER_BIT = 0x2000, 0x200
# The top tree's boxes are tested in world space, the triangles in object space after
# a float32 transform of the ray: widened by this share of their coordinates' size,
# a box never loses a ray that its instance's triangles hit.
TOP_PAD = 1.0e-5
# Mesh keys whose corners move under a fixed topology (engine/usd/read.py): refitted.
DEFORMED = ("skinned", "varying")


def _words(data) -> np.ndarray:
    """(n, 4) uint32: float32 records (ints among them as bits), as their words."""
    data = np.asarray(data)
    if data.dtype != np.uint32:
        data = np.ascontiguousarray(data, np.float32).view(np.uint32)
    return np.ascontiguousarray(data).reshape(-1, 4)


class RtData:
    """The arrays (SECTIONS) as one texture of 32-bit words, WIDTH vec4 a line, after a
    header vec4 of where each starts. A section written again at its size changes only
    its lines (a refit's trees and corners); a new size lays the texture out again, and
    until then the section waits in `_pending`: the texture's contents (`_words`) are the
    only copy of the others."""

    def __init__(self, ctx, uploads):
        self.ctx, self.uploads = ctx, uploads
        self.texture = None
        self._words = None            # the texture's contents, (lines * WIDTH, 4) uint32
        self._spans = {}              # section -> (first vec4, vec4s) in _words
        self._pending = {}            # section -> its (n, 4) words, at a new size
        self._dirty = []              # (first, end) vec4 ranges written since the upload

    @property
    def empty(self) -> bool:
        return self._words is None and "nodes" not in self._pending

    def set(self, name, data):
        words = _words(data)
        if name in self._spans and name not in self._pending and \
                self._spans[name][1] == len(words):
            self.put(name, 0, words)
        else:
            self._pending[name] = words

    def put(self, name, first, data):
        """Vec4s from `first` of section `name`, in place."""
        words = _words(data)
        if name in self._pending:
            self._pending[name][first:first + len(words)] = words
            return
        at = self._spans[name][0] + first
        self._words[at:at + len(words)] = words
        self._dirty.append((at, at + len(words)))

    def flush(self):
        """Brings the texture up to the arrays: laid out again, or the lines written."""
        if self._pending:
            self._lay_out()
            return
        for first, end in self._dirty:
            y0, y1 = first // WIDTH, -(-end // WIDTH)
            self.uploads.write_texture(self.texture, self._words[y0 * WIDTH:y1 * WIDTH],
                                       kind="raytrace", viewport=(0, y0, WIDTH, y1 - y0))
        self._dirty = []

    def _lay_out(self):
        arrays = {name: self._pending[name] if name in self._pending else
                  self._words[self._spans[name][0]:sum(self._spans[name])]
                  for name in SECTIONS}
        sizes = [len(arrays[name]) for name in SECTIONS]
        starts = np.cumsum([1] + sizes)[:-1]
        self._spans = {name: (int(a), n) for name, a, n in zip(SECTIONS, starts, sizes)}
        lines = -(-int(starts[-1] + sizes[-1]) // WIDTH)
        words = np.zeros((lines * WIDTH, 4), np.uint32)
        words[0] = starts
        for name, (a, n) in self._spans.items():
            words[a:a + n] = arrays[name]
        self._words, self._pending, self._dirty = words, {}, []
        texels = words.reshape(lines, WIDTH, 4)
        if self.texture is not None and self.texture.size == (WIDTH, lines):
            self.uploads.write_texture(self.texture, texels, kind="raytrace")
            return
        if self.texture is not None:
            self.texture.release()
        self.texture = self.uploads.texture((WIDTH, lines), 4, texels, kind="raytrace",
                                            dtype="u4")
        # Nearest: an integer texture with a linear filter is incomplete (reads 0).
        self.texture.filter = (self.ctx.NEAREST, self.ctx.NEAREST)

    def bind(self):
        self.flush()
        self.texture.use(UNITS["rt_data"])

    def release(self):
        if self.texture is not None:
            self.texture.release()
        self.__init__(self.ctx, self.uploads)


@dataclass
class Bottom:
    """One mesh's tree and triangles, and where they lie in the buffers."""
    mesh: object                  # the MeshData record it was built from
    tree: bvh.Tree
    triangles: np.ndarray         # (T, 3, 4) float32 as uploaded
    first_node: int = 0
    first_triangle: int = 0
    poses: int = 0                # SkinningPass.poses when its corners were read


@dataclass
class Hits:
    """Traced rays, as shaders/raytrace.glsl gives them: t (-1 where nothing was hit),
    instance (index into Raytracer.instances, -1: none), triangle (index into the
    triangle buffer), the barycentric weights (n, 2) of its v1 and v2, and what
    rt_hit_object, rt_hit_material (the name, None: no hit) and rt_hit_normal say."""
    t: np.ndarray
    instance: np.ndarray
    triangle: np.ndarray
    barycentric: np.ndarray
    local: np.ndarray             # the triangle's index in its mesh (-1: none)
    object: np.ndarray
    material: list
    normal: np.ndarray


def patch_triangles(patches, cage=None) -> np.ndarray:
    """(2P, 3, 3) float32: two triangles a Bezier patch, over its corners (which lie on
    the limit surface), in the order and winding of its u and v. `cage`: a skinned
    cage's points as posed, which the patches' stencils carry to the corners (else the
    patches' own control points)."""
    rows = (np.arange(len(patches.control))[:, None] * 16 + np.array([0, 3, 15, 12])).ravel()
    if cage is None:
        corners = patches.control.reshape(-1, 3)[rows]
    else:
        indptr, points, weights = patches.stencils
        start, count = indptr[rows], indptr[rows + 1] - indptr[rows]
        first = np.cumsum(count) - count          # each corner's first term, gathered
        at = np.repeat(start - first, count) + np.arange(count.sum())
        corners = np.add.reduceat(weights[at, None] * cage[points[at]], first)
    quads = corners.reshape(-1, 4, 3)
    return np.ascontiguousarray(quads[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3, 3), np.float32)


class Raytracer:
    def __init__(self, ctx, uploads, programs, geometry, skinning):
        self.ctx, self.uploads, self.programs = ctx, uploads, programs
        self.geometry, self.skinning = geometry, skinning
        self.bottoms = {}             # mesh key -> Bottom
        self.materials = []           # material names, by the index triangles carry
        self.instances = []           # (instance path, k-th of its worlds) per record
        self._first = np.zeros(0, np.int64)   # each record's first triangle
        self._left_out = []           # instances not traced, a line each
        self.counts = Counter()       # bottom_builds, refits, top_builds; triangles
        self.seconds = Counter()      # the same work's CPU seconds (uploads included); trace
        self.data = RtData(ctx, uploads)
        self._placed = None           # what the top tree was built from
        self._lo = self._hi = None    # every bottom tree's boxes (_pack)
        self.bounds = None            # (lo, hi) world box of every traced triangle, or None

    # --- keeping up with the scene -------------------------------------------------
    def update(self, scene):
        """Brings the trees up to `scene` as the GPU draws it: called after the frame's
        skinning pass (and Geometry.update: object ids come from its draws)."""
        used = {inst.mesh_key for inst in scene.instances.values()}
        for key in [k for k in self.bottoms if k not in used]:
            del self.bottoms[key]
            self._placed = None
        rebuilt, refits = False, []
        for key in sorted(used, key=repr):
            mesh = scene.meshes[key]
            old = self.bottoms.get(key)
            poses = self.skinning.poses.get(key, 0)
            if old is not None and old.mesh is mesh and old.poses == poses:
                continue
            t0 = time.perf_counter()                     # the corners' read-back included
            corners = self._corners(mesh)
            if corners is None:
                rebuilt |= self.bottoms.pop(key, None) is not None
                continue
            if old is not None and key[0] in DEFORMED and len(corners) == len(old.triangles):
                # Posed again, or a time-sampled mesh at a new time: the same tree
                # refitted, with the others below.
                old.mesh, old.poses = mesh, poses
                old.triangles = self._triangles(mesh, corners)
                refits.append((old, bvh.triangle_boxes(corners)))
                self.seconds["refits"] += time.perf_counter() - t0
                continue
            self.bottoms[key] = Bottom(mesh, bvh.build(*bvh.triangle_boxes(corners)),
                                       self._triangles(mesh, corners), poses=poses)
            self.counts["bottom_builds"] += 1
            self.seconds["bottom_builds"] += time.perf_counter() - t0
            rebuilt = True
        if refits:
            t0 = time.perf_counter()
            bvh.refit_many([b.tree for b, _ in refits], [b.first_node for b, _ in refits],
                           self._lo, self._hi, [box[0] for _, box in refits],
                           [box[1] for _, box in refits])
            if not rebuilt:                  # else every tree goes up below
                for b, _ in refits:
                    self._write_bottom(b)
            self.counts["refits"] += len(refits)
            self.seconds["refits"] += time.perf_counter() - t0
        if rebuilt or self.data.empty:                   # (empty: nothing traced yet)
            t0 = time.perf_counter()
            self._pack()
            self.seconds["bottom_builds"] += time.perf_counter() - t0
        self.counts["triangles"] = self.triangle_count
        self._place(scene, force=bool(refits) or rebuilt)

    def _corners(self, mesh):
        """(T, 3, 3) float32 corners of a mesh's triangles as drawn (a skinned mesh as
        the skinning pass left it), or None (no triangles)."""
        posed = mesh.skin is not None and mesh.key in self.skinning.poses
        if mesh.patches is not None:
            cage = None
            if posed and mesh.patches.stencils is not None:    # a skinned cage, as posed
                cage = np.zeros((mesh.skin.n_points, 3), np.float32)
                cage[mesh.point_of_vertex] = self.skinning.read(mesh.key)[:, :3]
            return patch_triangles(mesh.patches, cage)
        if not len(mesh.indices):
            return None
        points = mesh.vertices[:, :3]
        if posed:
            points = self.skinning.read(mesh.key)[:, :3]
        return np.ascontiguousarray(points[mesh.indices.reshape(-1, 3)], np.float32)

    def _triangles(self, mesh, corners) -> np.ndarray:
        """(T, 3, 4) float32: the corners, each triangle's material and index."""
        out = np.zeros((len(corners), 3, 4), np.float32)
        out[:, :, :3] = corners
        material = np.zeros(len(corners), np.int32)
        per = 2 if mesh.patches is not None else 3       # patches: 2 triangles each
        ranges = mesh.patches.ranges if mesh.patches is not None else mesh.ranges
        for mi, first, count in ranges:
            first, count = (first * 2, count * 2) if per == 2 else (first // 3, count // 3)
            material[first:first + count] = self._material(mesh.materials[mi])
        out[:, 0, 3] = material.view(np.float32)
        out[:, 1, 3] = np.arange(len(corners), dtype=np.int32).view(np.float32)
        return out

    def _material(self, name) -> int:
        if name not in self.materials:
            self.materials.append(name)
        return self.materials.index(name)

    def _pack(self):
        """Every bottom tree and its triangles into the buffers, one after another."""
        node = tri = 0
        for b in self.bottoms.values():
            b.first_node, b.first_triangle = node, tri
            node += b.tree.size
            tri += len(b.triangles)
        nodes = np.zeros((max(node, 1), bvh.NODE_FLOATS), np.float32)
        triangles = np.zeros((max(tri, 1), 3, 4), np.float32)
        # Every tree's boxes become views of one pair of arrays: refit_many's.
        self._lo, self._hi = np.zeros((node, 3), np.float32), np.zeros((node, 3), np.float32)
        for b in self.bottoms.values():
            span = slice(b.first_node, b.first_node + b.tree.size)
            self._lo[span], self._hi[span] = b.tree.lo, b.tree.hi
            b.tree.lo, b.tree.hi = self._lo[span], self._hi[span]
            nodes[span] = b.tree.packed(b.first_node)
            triangles[b.first_triangle:b.first_triangle + len(b.triangles)] = b.triangles
        self.data.set("nodes", nodes)
        self.data.set("triangles", triangles)
        self._placed = None

    def _write_bottom(self, b):
        """A refitted tree and its triangles, in place."""
        self.data.put("nodes", b.first_node * bvh.NODE_FLOATS // 4, b.tree.packed(b.first_node))
        self.data.put("triangles", 3 * b.first_triangle, b.triangles)

    def _place(self, scene, force: bool):
        """The instance records and the top tree, built again when an instance moved,
        came or went, or a tree's box changed (`force`)."""
        placed = [(path, inst.mesh_key, inst.world if inst.worlds is None else inst.worlds)
                  for path, inst in sorted(scene.instances.items())
                  if inst.mesh_key in self.bottoms]
        if not force and self._placed is not None and len(placed) == len(self._placed) and \
                all(a[:2] == b[:2] and np.array_equal(a[2], b[2])
                    for a, b in zip(placed, self._placed)):
            return
        self._placed = placed
        t0 = time.perf_counter()
        self._left_out = []
        worlds = np.zeros((0, 4, 4))
        if placed:
            # Every instance at once: one row per world matrix, `owner` its entry.
            worlds = [np.asarray(w, np.float64).reshape(-1, 4, 4) for _, _, w in placed]
            sizes = np.array([len(w) for w in worlds])
            owner = np.repeat(np.arange(len(placed)), sizes)
            k = np.arange(len(owner)) - np.repeat(np.cumsum(sizes) - sizes, sizes)
            worlds = np.concatenate(worlds)
            a = worlds[:, :3, :3]
            det = np.sum(a[:, 0] * cross(a[:, 1], a[:, 2]), axis=1)
            keep = np.abs(det) > SINGULAR * np.abs(a).max(axis=(1, 2)) ** 3
            for e in np.unique(owner[~keep]):
                self._left_out.append(
                    f"{placed[e][0]}: {int(np.sum(~keep & (owner == e)))} instance(s) of zero "
                    f"scale not ray traced")
            owner, k, worlds = owner[keep], k[keep], worlds[keep]
        if len(worlds):
            bottoms = [self.bottoms[key] for _, key, _ in placed]
            info = np.array([(b.first_node, b.first_triangle, len(b.triangles),
                              self.geometry.draws[path].oid)
                             for b, (path, _, _) in zip(bottoms, placed)], np.int32)[owner]
            info[:, 3] += k.astype(np.int32)
            records = np.empty((len(worlds), INSTANCE_VEC4 * 4), np.float32)
            records[:, :12] = affine_inverse(worlds)[:, :3].reshape(-1, 12)
            records[:, 12:24] = worlds[:, :3].reshape(-1, 12)
            records[:, 24:] = info.view(np.float32)
            self._first = info[:, 1].astype(np.int64)
            self.instances = [(placed[e][0], int(i)) for e, i in zip(owner, k)]
            root_lo = np.array([b.tree.lo[0] for b in bottoms], np.float64)[owner]
            root_hi = np.array([b.tree.hi[0] for b in bottoms], np.float64)[owner]
            lo, hi = transform_aabbs(root_lo, root_hi, worlds)
            self.bounds = (lo.min(axis=0), hi.max(axis=0))
            pad = TOP_PAD * (np.maximum(np.abs(lo), np.abs(hi)) + (hi - lo))
            top = bvh.build(lo - pad, hi + pad).packed()
            self.data.set("instances", records)
        else:
            self._first, self.instances = np.zeros(0, np.int64), []
            self.bounds = None
            top = np.zeros((1, bvh.NODE_FLOATS), np.float32)     # miss link 0: empty
            self.data.set("instances", np.zeros(INSTANCE_VEC4 * 4, np.float32))
        self.data.set("top", top)
        self.counts["top_builds"] += 1
        self.seconds["top_builds"] += time.perf_counter() - t0

    # --- using it ------------------------------------------------------------------
    def bind(self):
        """Binds the arrays' texture where shaders/raytrace.glsl reads it."""
        self.data.bind()

    @property
    def warnings(self) -> list:
        """What the tracer leaves out, one line each."""
        return list(self._left_out)

    @property
    def triangle_count(self) -> int:
        return sum(len(b.triangles) for b in self.bottoms.values())

    def trace(self, origins, directions, tmin=0.0, tmax=FAR, any_hit=False,
              brute_force=False) -> Hits:
        """Traces rays (n, 3) from `origins` along `directions` (shaders/trace.comp);
        `brute_force` tests every triangle instead of walking the trees (the trees'
        reference, for tests and the bench)."""
        origins = np.asarray(origins, np.float32).reshape(-1, 3)
        n = len(origins)
        rays = np.zeros((n, 2, 4), np.float32)
        rays[:, 0, :3], rays[:, 0, 3] = origins, tmin
        rays[:, 1, :3], rays[:, 1, 3] = np.asarray(directions, np.float32).reshape(-1, 3), tmax
        defines = ["ANY_HIT"] * any_hit + ["BRUTE_FORCE"] * brute_force
        prog = self.programs.get("trace.comp", None, defines, compute=True)
        ray_buffer = self.uploads.buffer(rays, kind="raytrace")
        hit_buffer = self.uploads.buffer(reserve=n * 48, kind="raytrace")
        try:
            self.bind()
            ray_buffer.bind_to_storage_buffer(0)
            hit_buffer.bind_to_storage_buffer(1)
            set_uniform(prog, "u_rays", n)
            set_uniform(prog, "u_instances", len(self.instances))
            groups = max(-(-n // GROUP), 1)
            across = min(groups, MAX_GROUPS)
            self.ctx.finish()
            t0 = time.perf_counter()
            prog.run(across, -(-groups // across))
            self.ctx.memory_barrier(SHADER_STORAGE_BARRIER_BIT | BUFFER_UPDATE_BARRIER_BIT)
            self.ctx.finish()
            self.seconds["trace"] = time.perf_counter() - t0          # the last batch's
            out = np.frombuffer(hit_buffer.read(), np.float32).reshape(n, 3, 4)
        finally:
            ray_buffer.release()
            hit_buffer.release()
        instance = out[:, 0, 1].view(np.int32).copy()
        triangle = out[:, 0, 2].view(np.int32).copy()
        hit = instance >= 0
        local = np.full(n, -1, np.int64)
        local[hit] = triangle[hit] - self._first[instance[hit]]
        material = [self.materials[m] if m >= 0 else None for m in out[:, 1, 2].view(np.int32)]
        return Hits(out[:, 0, 0].copy(), instance, triangle, out[:, 1, :2].copy(), local,
                    out[:, 0, 3].view(np.int32).copy(), material, out[:, 2, :3].copy())

    def release(self):
        self.data.release()
        self.bottoms.clear()
