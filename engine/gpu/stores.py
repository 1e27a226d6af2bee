"""Meshes' vertices and indices on the GPU, many meshes to one pair of buffers.

  static store    every static mesh's vertices and indices in two large shared
                  buffers, written when the mesh is read and never again (a
                  time-sampled mesh is rewritten in place each frame).
  dynamic store   the same layout, written every frame by the skinning pass (transform
                  feedback); a skinned mesh's indices go up once.
(The static and dynamic branches of the pipeline: docs/design.md.) Indices are
absolute in their store, so a draw needs no base vertex (GL 3.3 has none in ModernGL).
A store that is full grows: a buffer twice as large, the old contents copied inside
the GPU, and the VAOs made over the old buffers dropped (`generation`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import STREAM_WIDTHS

VERTEX_FORMAT = ("3f 3f 2f 4f", "in_pos", "in_normal", "in_uv", "in_tangent")
VERTEX_BYTES = 48
# Per-vertex data only some networks read (engine/scene.py MeshData.streams): a buffer
# each beside the vertices, same vertex numbers, made when a first mesh has that stream.
# name -> the vertex shader's attribute; floats a vertex: engine/scene.py STREAM_WIDTHS.
STREAMS = {"colors": "in_color", "generated": "in_generated"}


class Arena:
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
        self.vertices = Arena(vertices)
        self.indices = Arena(indices)
        self.vbo = uploads.buffer(reserve=vertices * VERTEX_BYTES, kind="mesh")
        self.ibo = uploads.buffer(reserve=indices * 4, kind="mesh")
        self.streams = {}             # stream name -> buffer beside the vertices (STREAMS)
        self.generation = 0           # bumps when the buffers are replaced (VAOs go stale)
        self._vaos = {}

    def alloc(self, n_vertices: int, n_indices: int) -> Slot:
        v = self._alloc(self.vertices, n_vertices, "vbo", VERTEX_BYTES)
        i = self._alloc(self.indices, n_indices, "ibo", 4)
        return Slot(v, n_vertices, i, n_indices)

    def _alloc(self, arena, n, attr, unit):
        start = arena.alloc(n)
        if start is None:
            capacity = max(arena.capacity * 2, arena.capacity + n)
            setattr(self, attr, self._grown(getattr(self, attr), arena.capacity, capacity, unit))
            if attr == "vbo":
                for name, buffer in self.streams.items():
                    self.streams[name] = self._grown(buffer, arena.capacity, capacity,
                                                     4 * STREAM_WIDTHS[name])
            arena.grow(capacity)
            self._drop_vaos()
            start = arena.alloc(n)
        return start

    def _grown(self, old, capacity, new_capacity, unit):
        new = self.uploads.buffer(reserve=new_capacity * unit, kind="mesh")
        self.ctx.copy_buffer(new, old, size=capacity * unit)     # inside the GPU
        # NVIDIA's driver (580) can lose the copied part when the new buffer is written
        # before the copy has run (docs/gpu.md "Store growth on NVIDIA"); llvmpipe never
        # does. A store doubles a few times a session, so waiting here costs little.
        self.ctx.finish()
        old.release()
        return new

    def free(self, slot: Slot):
        self.vertices.release(slot.first_vertex, slot.n_vertices)
        self.indices.release(slot.first_index, slot.n_indices)

    def write_vertices(self, slot: Slot, vertices: np.ndarray):
        self.uploads.write(self.vbo, np.ascontiguousarray(vertices, np.float32), kind="mesh",
                           offset=slot.first_vertex * VERTEX_BYTES)

    def write_stream(self, slot: Slot, name: str, values: np.ndarray):
        if name not in self.streams:
            self.streams[name] = self.uploads.buffer(
                reserve=self.vertices.capacity * 4 * STREAM_WIDTHS[name], kind="mesh")
            self._drop_vaos()          # the VAOs made before lack the stream
        self.uploads.write(self.streams[name], np.ascontiguousarray(values, np.float32),
                           kind="mesh", offset=slot.first_vertex * 4 * STREAM_WIDTHS[name])

    def write_indices(self, slot: Slot, indices: np.ndarray):
        absolute = np.asarray(indices, np.uint32) + np.uint32(slot.first_vertex)
        self.uploads.write(self.ibo, absolute, kind="mesh", offset=slot.first_index * 4)

    def vao(self, prog, ids=None):
        """The VAO of this store for `prog` (with the object-id attribute when `ids`)."""
        key = (id(prog), id(ids))
        vao = self._vaos.get(key)
        if vao is None:
            content = [(self.vbo, *VERTEX_FORMAT)]
            content += [(buffer, f"{STREAM_WIDTHS[name]}f", STREAMS[name])
                        for name, buffer in self.streams.items()]
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
        for buffer in (self.vbo, self.ibo, *self.streams.values()):
            buffer.release()
        self.streams.clear()
