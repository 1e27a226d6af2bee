"""The light-culling pass of clustered lighting (GL 4.3 compute; Frame.lighting
"clustered"): on the GPU, every frame, each cluster of the screen (TILE x TILE pixel
tiles, each tile's own depth range in SLICES slices: shaders/clusters.glsl) gets the
list of lights that reach it, which the clustered light pass (passes/clustered.py)
then shades per pixel.

  light_tiles.comp   one work group a tile: its surfaces' view-depth range and the
                     slices that hold one (a tile of background lists nothing)
  light_cull.comp    one invocation a cluster, counting, then writing: its box, then
                     the lights shaded one by one and the light tree's nodes
                     (engine/light_tree.py: groups where far enough for the error bound,
                     else single lights) and the lights shaded one by one, each where
                     it reaches (a light with a volume: where its sphere meets the box)

Lists go into one pool of items, each cluster taking its place with an atomic add.
A cluster whose list does not fit is marked and walks every light when shaded (never
dropped). The first frame after the lights, the error bound or the grid changed reads
how many items were asked for at once and culls again into a pool of that size (one
wait on the GPU, then never again for them); later frames read it with their pixels
and grow the pool for the next frame (stats light_items, clusters_overflowed), so a
moving view never waits mid-frame. The light pass adds to the same counts the pixels
that walked the light tree and their steps (nodes visited): stats light_tree_pixels,
light_tree_steps (all of them) and light_tree_steps_max (one pixel's most).

Lights whose shadows have a map this frame are not listed: each is a pass of its own
with its map, a dispatch over its screen rectangle (passes/clustered.py) or, where the
screen passes are raster, its light volume (passes/lights.py).

reads: g_depth, view, shadow_maps (optional)   writes: clusters (a Clusters record)"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from ..readback import SLOTS
from ...view import relative_view

TILE = 16            # shaders/clusters.glsl
SLICES = 8
ITEMS_PER_CLUSTER = 16   # the pool's first size, per cluster
TILE_TEXELS, RANGE_BYTES, COUNT_BYTES = 16, 16, 24


@dataclass
class Clusters:
    """What the culling hands to the clustered light pass."""
    tiles: tuple            # tiles across, down
    exact: list             # light paths shaded one by one from the lists
    mapped: list            # light paths shaded one by one with their shadow maps
    tree: object            # LightTree or None
    error: float
    counts: object          # the buffer of items asked and clusters overflowed


def light_kinds(table, shadow_maps):
    """(lights shaded one by one from the lists, lights shaded with their maps):
    every light outside the tree (LightTable.one_by_one), split by whether its map
    was made this frame."""
    exact, mapped = [], []
    for path in table.one_by_one:
        (mapped if path in shadow_maps else exact).append(path)
    return exact, mapped


class LightCullPass(Pass):
    name = "light_cull"
    reads = ("g_depth", "view")
    optional = ("shadow_maps",)
    writes = ("clusters",)

    def __init__(self, ctx, programs, uploads, table):
        self.ctx, self.programs, self.uploads, self.table = ctx, programs, uploads, table
        self._tiles = self._ranges = self._items = None
        self._counts = []             # one count buffer a frame in flight
        self._next = 0
        self._exact = None            # (rows, buffer) of the lights listed one by one
        self.capacity = 0             # items the pool holds
        self._grid = None
        self._sized = None            # (lights version, error, grid) the pool was sized for

    def needed(self, frame):
        return frame.lighting == "clustered" and bool(frame.scene.lights)

    def execute(self, frame, board):
        ctx, view = self.ctx, board["view"]
        w, h = frame.size
        tiles = (-(-w // TILE), -(-h // TILE))
        n_clusters = tiles[0] * tiles[1] * SLICES
        self._size_buffers(tiles, n_clusters)
        error = float(frame.options.light_error)
        tree, tree_texture = self.table.tree_for(frame.scene, error)
        exact, mapped = light_kinds(self.table, board.get("shadow_maps", {}))
        rows = np.array([self.table.index[p] for p in exact] or [0], np.int32)
        if self._exact is None or not np.array_equal(self._exact[0], rows):
            if self._exact is not None:
                self._exact[1].release()
            self._exact = (rows, self.uploads.buffer(rows, kind="lights"))
        counts = self._counts[self._next]
        self._next = (self._next + 1) % len(self._counts)
        counts.clear()
        board["clusters"] = Clusters(tiles, exact, mapped, tree, error, counts)
        frame.stats["light_clusters"] = n_clusters
        if not exact and tree is None:
            return                  # every light has its map: nothing to list
        self.bind(tree_texture, counts)
        board["g_depth"].use(UNITS["g_depth"])

        prog = self.programs.get("light_tiles.comp", compute=True)
        view.set_camera(prog)
        set_uniform(prog, "cluster_tiles", tiles)
        prog.run(*tiles)
        ctx.memory_barrier()

        self.table.texture.use(UNITS["u_lights"])
        count = self._cull_program("light_cull.comp", view, tiles, (w, h), tree, error, exact)
        groups = -(-n_clusters // 64)
        count.run(groups)
        ctx.memory_barrier()
        sized = (self.table.version, error, tiles)
        if self._sized != sized:
            self._sized = sized
            asked = int(np.frombuffer(counts.read(), np.uint32)[0])
            if asked > self.capacity:
                self._grow(asked + asked // 4)
                self.bind(tree_texture, counts)
                counts.clear()
                set_uniform(count, "items_capacity", self.capacity)
                count.run(groups)
                ctx.memory_barrier()
        write = self._cull_program("light_cull.comp", view, tiles, (w, h), tree, error, exact,
                                   ["CULL_WRITE"])
        write.run(groups)
        ctx.memory_barrier()

    def _cull_program(self, name, view, tiles, size, tree, error, exact, defines=()):
        prog = self.programs.get(name, defines=defines, compute=True)
        view.set_camera(prog)
        set_uniform(prog, "cluster_tiles", tiles)
        set_uniform(prog, "u_size", (float(size[0]), float(size[1])))
        set_uniform(prog, "world_to_view", relative_view(view.camera)[:3, :3])
        set_uniform(prog, "items_capacity", self.capacity)
        set_tree_uniforms(prog, tree, error)
        set_uniform(prog, "n_exact", len(exact))
        return prog

    def bind(self, tree_texture, counts):
        """The culling's buffers at the binding points the shaders name, and the light
        tree's texture at its unit."""
        self._tiles.bind_to_storage_buffer(4)
        self._ranges.bind_to_storage_buffer(5)
        self._items.bind_to_storage_buffer(6)
        counts.bind_to_storage_buffer(7)
        self._exact[1].bind_to_storage_buffer(8)
        if tree_texture is not None:
            tree_texture.use(UNITS["u_tree"])

    def finish(self, frame, clusters):
        """Reads a frame's counts (its pixels are in host memory, so this waits on
        nothing) into its stats, and grows the pool when its lists did not fit."""
        asked, overflowed, pixels, most, low, high = (
            int(v) for v in np.frombuffer(clusters.counts.read(), np.uint32))
        frame.stats["light_items"] = asked
        frame.stats["clusters_overflowed"] = overflowed
        frame.stats["light_tree_pixels"] = pixels
        frame.stats["light_tree_steps"] = (high << 32) + low
        frame.stats["light_tree_steps_max"] = most
        if asked > self.capacity:
            self._grow(asked + asked // 4)

    def _size_buffers(self, tiles, n_clusters):
        if self._grid == tiles:
            return
        self._release_grid()
        self._grid = tiles
        self._tiles = self.ctx.buffer(reserve=tiles[0] * tiles[1] * TILE_TEXELS)
        self._ranges = self.ctx.buffer(reserve=n_clusters * RANGE_BYTES)
        if not self._counts:
            self._counts = [self.ctx.buffer(reserve=COUNT_BYTES) for _ in range(SLOTS)]
        self._grow(max(self.capacity, n_clusters * ITEMS_PER_CLUSTER))

    def _grow(self, capacity):
        if self._items is not None:
            self._items.release()
        self.capacity = int(capacity)
        self._items = self.ctx.buffer(reserve=self.capacity * 4)

    def _release_grid(self):
        for buf in (self._tiles, self._ranges):
            if buf is not None:
                buf.release()
        self._tiles = self._ranges = None

    def release(self):
        self._release_grid()
        for buf in self._counts:
            buf.release()
        self._counts = []
        if self._items is not None:
            self._items.release()
            self._items = None
        if self._exact is not None:
            self._exact[1].release()
            self._exact = None


def set_tree_uniforms(prog, tree, error):
    set_uniform(prog, "tree_leaves", 0 if tree is None else int(tree.leaves))
    set_uniform(prog, "tree_exact", error <= 0.0)
    set_uniform(prog, "light_error", float(error))
