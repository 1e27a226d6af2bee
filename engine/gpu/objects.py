"""Per-object data on the GPU: each drawn object's model and normal matrices.

  object table    per object (a Mesh prim drawn), its model and normal matrices: 8
                  RGBA32F texels in one texture, indexed by object id, so moving an
                  object writes 128 bytes. The translation is a double split in two
                  floats (hi in the matrix's fourth column, lo in texel 7): shaders
                  subtract the frame's origin from it (camera-relative rendering,
                  engine/view.py), so the table does not change when the view does."""
from __future__ import annotations

import numpy as np

from ...core.transforms import normal_matrix
from ..view import split_double
from .stores import Arena

OBJECT_TEXELS = 8            # model matrix columns (4), normal matrix columns (3), lo translation
OBJECT_TEX_W = 4096          # 512 objects per row: an object never straddles rows


class ObjectTable:
    """Per-object model and normal matrices in one RGBA32F texture (shaders/objects.glsl
    reads them). The instances of an instanced draw take consecutive ids, so one
    command (baseInstance = the first, instanceCount = n) draws them all."""

    def __init__(self, ctx, uploads, rows: int = 1):
        self.ctx, self.uploads = ctx, uploads
        self.data = np.zeros((rows, OBJECT_TEX_W, 4), np.float32)
        self.texture = None
        self._id_space = Arena(self.capacity)
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
        texels[:, 4:7, :3] = normal_matrix(worlds).transpose(0, 2, 1)
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
