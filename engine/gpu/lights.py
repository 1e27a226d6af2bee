"""Lights on the GPU: one packed RGBA32F table, a row per light, written when a light
changes. Every light draw, one at a time or instanced, reads its light from the table
by index (shaders/light_table.glsl), so a light's numbers go up once, not per draw.
LIGHTS_PER_LINE rows lie side by side on each texture line, so any number of lights
fits GL's texture size limit (16384 lines on llvmpipe).

Row layout (texels, must match shaders/lights.glsl):
  0 position (hi), volume radius R   1 colour (I, L or E), sphere radius
  2 emission direction, cos(cone)    3 cone softness, diffuse, specular, flags
  4 x axis, half width (disk: rx)    5 y axis, half height (disk: ry)
  6 polygon vertices, area, first polygon row, polygon rows
  7 position (lo)
  8.. polygon vertices about the position (rect 4, disk an N-gon)
flags: 1 soft falloff, 2 spot, 4 disk, 8 headlight (shines along the view), 16 distant
(a sun: shaders/lights.glsl's light_radiance picks the kind by these), 32 two-sided.
An emissive mesh's polygons (kind POLYGON, engine/emitters.py) are one light: its row
holds the first polygon (its radiance in 1, its front in 2, flag 32 where it lights
from both faces, its corners about the light's position), and each other polygon a
row of the same form past the lights' rows (POLYGON ROWS, numbered in texel 6); the
position, x and y axes and half sizes are the box they lie in, over which their one
shadow is filtered. After its polygon rows come its groups' rows (engine/emitter_groups.py,
the inner nodes of a tree over its polygons, node i at first polygon row + polygon rows
+ i): 1 mean radiance, 2 front, 3 flags (32), 4 |first moment| per channel, radius,
5 deviation per channel, polygons, 6 corners (4, or 0 where it may not stand for its
polygons), area, 8..11 its rect about the light's position.
The position is a double split in two floats: shaders make it camera-relative
(shaders/origin.glsl), so the table does not change when the view does.

Clustered lighting also reads the light tree (engine/light_tree.py) of the point
lights without shadows, as a second RGBA32F texture of NODES_PER_LINE nodes a line
(shaders/light_tree.glsl): built when a clustered frame first asks for it after the
lights or the error bound changed (tree_for). A texture, not a storage buffer: a
pixel's walk reads every node it visits, and llvmpipe fetches texels several times
faster than it loads from a storage buffer (a dense field of lights' light pass took
2.6 times the CPU time from a buffer)."""
from __future__ import annotations

import numpy as np

from ...core.lights import DISK, POLYGON, RECT, SPOT, SUN
from .. import emitter_groups, light_tree
from ..lighting import disk_polygon, disk_semi_axes, light_area, rect_polygon, volume_radius, volume_threshold
from ..shadow_plan import casts
from ..view import split_double

MAX_POLY = 32
ROW_TEXELS = 8 + MAX_POLY
LIGHTS_PER_LINE = 64        # rows per texture line: shaders/light_table.glsl
NODES_PER_LINE = 256        # light tree nodes per texture line: shaders/light_tree.glsl


def pack_rows(lights, ranges, disk_sides: int) -> np.ndarray:
    """(len(lights), ROW_TEXELS, 4) float32 rows of `lights` with their volume radii
    `ranges`: each column filled for all lights at once (a stage of 16,384 lights
    took 0.3 s packed light by light), then the polygons of the area lights."""
    n = len(lights)
    rows = np.zeros((n, ROW_TEXELS, 4), np.float32)
    if n == 0:
        return rows
    hi, lo = split_double([light.position for light in lights])
    rows[:, 0, :3], rows[:, 0, 3], rows[:, 7, :3] = hi, ranges, lo
    rows[:, 1, :3] = [light.color for light in lights]
    rows[:, 1, 3] = [light.radius for light in lights]
    axes = np.array([light.axis for light in lights], np.float64)
    rows[:, 2, :3] = axes / np.maximum(np.linalg.norm(axes, axis=1), 1e-30)[:, None]
    rows[:, 2, 3] = np.cos(np.radians(np.minimum([light.cone_angle for light in lights], 180.0)))
    rows[:, 3] = [(light.cone_softness, light.diffuse, light.specular, _flags(light))
                  for light in lights]
    for row, light in zip(rows, lights):
        if light.kind in (RECT, DISK, POLYGON):
            _pack_polygon(row, light, disk_sides)
    return rows


def _flags(light) -> int:
    return (1 if light.soft_falloff else 0) | (2 if light.kind == SPOT else 0) | \
        (4 if light.kind == DISK else 0) | (8 if light.headlight else 0) | \
        (16 if light.kind == SUN else 0) | \
        (32 if light.kind == POLYGON and light.two_sided[0] else 0)


def _pack_polygon(row, light, disk_sides: int):
    """An area light's axes, half sizes and (first) polygon (texels 4-6 and 8..)."""
    if light.kind == DISK:
        verts = disk_polygon(light, disk_sides)
        half = disk_semi_axes(light)
    else:
        verts = rect_polygon(light) if light.kind == RECT else light.polygons[0]
        half = (light.width / 2, light.height / 2)
    if light.kind == POLYGON:
        row[1, :3] = light.polygon_colors[0]
        row[2, :3] = _front(verts)
    row[4] = [*light.x_axis, half[0]]
    row[5] = [*light.y_axis, half[1]]
    row[6, :2] = [len(verts), light_area(light)]
    row[8:8 + len(verts), :3] = verts - np.asarray(light.position, np.float64)


def _front(corners) -> np.ndarray:
    n = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    return n / np.linalg.norm(n)


def extra_polygons(light) -> int:
    """How many polygon rows a light has past its own (an emissive mesh's polygons
    after the first)."""
    return len(light.polygons) - 1 if light.kind == POLYGON else 0


def extra_rows(light) -> int:
    """How many rows a light has past its own: its polygons after the first and its
    groups (an emissive mesh's)."""
    count = extra_polygons(light)
    return count + emitter_groups.leaves(count + 1) - 1 if count else 0


def pack_extra(light) -> np.ndarray:
    """(extra_rows(light), ROW_TEXELS, 4) float32 polygon and group rows of `light`."""
    rows = np.zeros((extra_rows(light), ROW_TEXELS, 4), np.float32)
    centre = np.asarray(light.position, np.float64)
    for row, corners, colour, both in zip(rows, light.polygons[1:], light.polygon_colors[1:],
                                          light.two_sided[1:]):
        row[1, :3] = colour
        row[2, :3] = _front(corners)
        row[3, 3] = 32 if both else 0
        row[6, 0] = len(corners)
        row[8:8 + len(corners), :3] = corners - centre
    if len(rows):
        g = emitter_groups.build(light.polygons, light.polygon_colors, light.two_sided)
        nodes = rows[extra_polygons(light):]
        nodes[:, 1, :3], nodes[:, 2, :3] = g.radiance, g.front
        nodes[:, 3, 3] = np.where(g.both, 32, 0)
        nodes[:, 4, :3], nodes[:, 4, 3] = g.moment, g.radius
        nodes[:, 5, :3], nodes[:, 5, 3] = g.deviation, g.count
        nodes[:, 6, 0], nodes[:, 6, 1] = np.where(g.flat, 4, 0), g.area
        nodes[:, 8:12, :3] = g.corners - centre
    return rows


class LightTable:
    def __init__(self, uploads):
        self.uploads = uploads
        self.disk_sides = None     # the preset's polygon for disk lights, as packed
        self.texture = None
        self.index = {}            # light path -> row
        self.extras = {}           # light path -> (first, count) of its polygon and group rows
        self.ranges = {}           # light path -> volume radius R
        self.threshold = None      # the scene's volume threshold the ranges use
        self.version = 0           # counts the updates that changed a light
        self.tree = None           # (version, error, LightTree or None, texture or None)
        # What the passes ask of every light each frame, sorted once per change (a
        # Python loop over 16,384 lights a pass took 5-30 ms a frame):
        self.casting = []          # paths of the lights that get a shadow map (casts)
        self.one_by_one = []       # paths shaded one by one, not through the tree
        self.has_disk = False

    def update(self, scene, changed: set, disk_sides: int):
        """Rows for the lights in `changed`; the whole table when lights were added or
        removed (rows follow the scene's light order) or the preset's disk polygon
        changed (only when a disk light draws with it: a viewport moving between its
        interactive preset and the scene's uploads nothing for the others)."""
        if changed:
            self.has_disk = any(light.kind == DISK for light in scene.lights.values())
        if self.disk_sides is not None and not self.has_disk:
            disk_sides = self.disk_sides
        if not changed and self.texture is not None and disk_sides == self.disk_sides:
            return
        self.version += 1
        self._write(scene, changed, disk_sides)
        self.casting = [p for p, light in scene.lights.items() if casts(light, self.ranges[p])]
        self.one_by_one = [p for p, light in scene.lights.items()
                           if not light_tree.in_tree(light)]

    def _write(self, scene, changed: set, disk_sides: int):
        """The rows and ranges of `update`: all of them, or those of `changed`."""
        paths = list(scene.lights)
        threshold = volume_threshold(scene.lights.values())
        if paths != list(self.index) or self.texture is None or \
                disk_sides != self.disk_sides or threshold != self.threshold or \
                any(extra_rows(scene.lights[p]) != self.extras.get(p, (0, 0))[1]
                    for p in changed if p in scene.lights):
            self.disk_sides = disk_sides
            self.index = {p: i for i, p in enumerate(paths)}
            self.threshold = threshold
            self.ranges = {p: volume_radius(scene.lights[p], threshold) for p in paths}
            self.extras, first = {}, len(paths)
            for p in paths:
                count = extra_rows(scene.lights[p])
                if count:
                    self.extras[p] = (first, count)
                    first += count
            lines = max(-(-first // LIGHTS_PER_LINE), 1)
            rows = np.zeros((lines * LIGHTS_PER_LINE, ROW_TEXELS, 4), np.float32)
            rows[:len(paths)] = pack_rows([scene.lights[p] for p in paths],
                                          [self.ranges[p] for p in paths], self.disk_sides)
            for p, (at, count) in self.extras.items():
                rows[self.index[p], 6, 2:] = at, extra_polygons(scene.lights[p])
                rows[at:at + count] = pack_extra(scene.lights[p])
            self.texture = self.uploads.rewrite_float_texture(
                self.texture, rows.reshape(lines, LIGHTS_PER_LINE * ROW_TEXELS, 4), kind="lights")
            return
        for p in changed:
            if p in self.index:
                light = scene.lights[p]
                self.ranges[p] = volume_radius(light, threshold)
                row = pack_rows([light], [self.ranges[p]], self.disk_sides)
                at, count = self.extras.get(p, (0, 0))
                row[0, 6, 2:] = at, extra_polygons(light)
                self._write_rows(self.index[p], row)
                if count:
                    self._write_rows(at, pack_extra(light))

    def _write_rows(self, first: int, rows: np.ndarray):
        """Rows (n, ROW_TEXELS, 4) into the table from row `first`, a line's run at a time."""
        i = 0
        while i < len(rows):
            at = first + i
            run = min(len(rows) - i, LIGHTS_PER_LINE - at % LIGHTS_PER_LINE)
            self.uploads.write_texture(
                self.texture, rows[i:i + run].reshape(1, run * ROW_TEXELS, 4), kind="lights",
                viewport=((at % LIGHTS_PER_LINE) * ROW_TEXELS, at // LIGHTS_PER_LINE,
                          run * ROW_TEXELS, 1))
            i += run

    def tree_for(self, scene, error: float):
        """(LightTree or None, its nodes' texture or None): the tree of the scene's
        tree lights (light_tree.in_tree) for the error bound, rebuilt only when a light
        or the bound changed since it was built."""
        if self.tree is not None and self.tree[:2] == (self.version, error):
            return self.tree[2:]
        self._release_tree()
        paths = [p for p, light in scene.lights.items() if light_tree.in_tree(light)]
        tree = light_tree.build([scene.lights[p] for p in paths],
                                [self.index[p] for p in paths],
                                [self.ranges[p] for p in paths], error)
        texture = None
        if tree is not None:
            lines = -(-len(tree.nodes) // NODES_PER_LINE)
            texels = np.zeros((lines * NODES_PER_LINE,) + tree.nodes.shape[1:], np.float32)
            texels[:len(tree.nodes)] = tree.nodes
            texture = self.uploads.float_texture(
                texels.reshape(lines, NODES_PER_LINE * tree.nodes.shape[1], 4), kind="lights")
        self.tree = (self.version, error, tree, texture)
        return tree, texture

    def _release_tree(self):
        if self.tree is not None and self.tree[3] is not None:
            self.tree[3].release()
        self.tree = None

    def release(self):
        self._release_tree()
        if self.texture is not None:
            self.texture.release()
