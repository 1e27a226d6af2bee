"""Meshes whose material emits, as lights: the emitting polygons of each placed mesh
are one light (core/lights.py POLYGON) in Scene.lights, each polygon shaded as an area
light's (shaders/lights.glsl area_light: LTC, diffuse and GGX), in one draw or one
entry of a cluster's list for the mesh, and all of them under one shadow: an area
light's (one map from the middle of the box they lie in, filtered over that box,
shaders/shadow_lookup.glsl), exact in the way a rect light's is for a flat rectangular
emitter, approximate for others (a lone triangle is shadowed as its box; a curved mesh
as its box). The emitting mesh casts nothing into its own lights' maps: a closed mesh
lies around its box's middle, and a convex one never shadows its own light (a
concave one does, in Cycles, and not here). So a closed mesh lights from its front
faces only, whatever its sampling: its back faces light its inside, which it hides
from everything else (an emissive sphere around a scene lights it when its normals
point inwards, or with Back sampling). The surface still shows its own emission
(the G-buffer's emissive channel); these lights are what it sends to the others.

Which faces light: the material's emission sampling (core/emission.py): none, the
front face (the side the mesh's normals point to), the back face, or both (Cycles'
Auto). The radiance is the material's emissive colour, W/(sr m2) (the stage contract,
"Emission"), which a rect light of the same size and power has too; a textured
emission is, per triangle, the texture's mean over the triangle's UVs (the mip level
whose texel covers them, at their centre; times its scale, plus its bias), a pattern
graph's its constant: within a triangle the light is uniform.

Polygons: the mesh's triangles, world space, a pair that makes a planar convex quad
(a quad's two triangles, as triangulation leaves them side by side) merged into one.
A mesh of more than CHUNK is several lights, each of polygons that lie together, each
with its own shadow over its own box.
Skinned, blend-shaped and GPU-subdivided meshes are not made lights (a warning: their
triangles are posed on the GPU).

A sync makes lights only for the instances whose mesh, material or placement changed
(Changes), and reports the lights it added, changed or dropped in Changes.lights."""
from __future__ import annotations

import functools

import numpy as np

from ..core.emission import SAMPLING
from ..core.lights import POLYGON
from ..core.morton import BITS, morton_codes, morton_order
from .mesh_topology import closed
from .scene import Light
from .textures import map_value, read_image_linear

WARNINGS = "<emitters>"          # Scene.warnings key of the meshes not made lights
COPLANAR = 1.0 - 1e-6           # cos between the normals of a quad's two triangles
# Polygons a light at most: a pixel near a light may walk its every group and polygon
# (511 steps, about 60 loop iterations a polygon), and llvmpipe ends an invocation's
# loops after 65,535 in all.
CHUNK = 256


@functools.lru_cache(maxsize=64)
def _texture_mean(path: str, colorspace: str) -> tuple:
    """The mean linear RGBA of an image file (read once with its halvings)."""
    return tuple(float(c) for c in _texture_mips(path, colorspace)[0].reshape(-1, 4).mean(axis=0))


def radiance(material) -> np.ndarray:
    """The emitted radiance (rgb, W/(sr m2)) a material's polygons light others with:
    its emissive colour, or its emission texture's mean."""
    ref = material.maps.get("emissiveColor")
    if ref is None:
        return np.asarray(material.emissive, np.float64)
    return map_value(ref, np.asarray(_texture_mean(ref.path, ref.colorspace)))


def _merge_quad(a, b):
    """The planar convex quad two front-wound triangles (3, 3) make when they share an
    edge, its corners in order, or None."""
    match = [next((i for i in range(3) if np.array_equal(a[i], q)), -1) for q in b]
    if sorted(m >= 0 for m in match) != [False, True, True]:
        return None
    other = b[match.index(-1)]
    i, j = sorted(m for m in match if m >= 0)
    # Put the other corner between the shared edge's ends in a's order (after a[2]
    # for the edge a[2] -> a[0]).
    corners = [a[0], a[1], a[2]]
    if (i, j) == (0, 2):
        corners.append(other)
    else:
        corners.insert(j, other)
    quad = np.array(corners)
    n = np.cross(a[1] - a[0], a[2] - a[0])
    edges = np.roll(quad, -1, axis=0) - quad
    turns = np.cross(edges, np.roll(edges, -1, axis=0)) @ n
    return quad if np.all(turns > 0) else None


@functools.lru_cache(maxsize=4)     # full-size float images: a few at a time
def _texture_mips(path: str, colorspace: str) -> tuple:
    """An image's linear RGBA and its box-filtered halvings, down to a texel."""
    levels = [read_image_linear(path, colorspace).astype(np.float32)]
    while min(levels[-1].shape[:2]) > 1:
        a = levels[-1]
        h, w = a.shape[0] // 2 * 2, a.shape[1] // 2 * 2
        levels.append(a[:h, :w].reshape(h // 2, 2, w // 2, 2, 4).mean(axis=(1, 3)))
    return tuple(levels)


def triangle_radiance(material, uvs: np.ndarray) -> np.ndarray:
    """(T, 3) radiance each triangle of UVs `uvs` (T, 3, 2) lights others with: an
    emission texture's mean over the triangle (the mip level whose texel covers its
    UV area, read at its UV centre, repeating), else the emissive colour. A texture's
    mean over the whole image would light a lamp's dark frame as its bright bulb."""
    ref = material.maps.get("emissiveColor")
    if ref is None or not len(uvs):
        return np.tile(np.asarray(material.emissive, np.float64), (len(uvs), 1))
    mips = _texture_mips(ref.path, ref.colorspace)
    h, w = mips[0].shape[:2]
    e1, e2 = uvs[:, 1] - uvs[:, 0], uvs[:, 2] - uvs[:, 0]
    texels = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) * w * h
    level = np.clip(np.floor(0.5 * np.log2(np.maximum(texels, 1.0))), 0, len(mips) - 1)
    centre = uvs.mean(axis=1)
    out = np.empty((len(uvs), 4))
    for k in np.unique(level).astype(int):
        pick = level == k
        img = mips[k]
        x = np.mod(centre[pick, 0], 1.0) * img.shape[1]
        y = np.mod(1.0 - centre[pick, 1], 1.0) * img.shape[0]     # row 0 = the image's top
        out[pick] = img[np.minimum(y.astype(int), img.shape[0] - 1),
                        np.minimum(x.astype(int), img.shape[1] - 1)]
    return map_value(ref, out)


def polygons(tris: np.ndarray, normals: np.ndarray, colors=None) -> list:
    """Front-wound polygons (each (3 or 4, 3)) of world triangles `tris` (T, 3, 3) whose
    vertex normals are `normals` (T, 3, 3): degenerate ones dropped, a planar convex
    quad's two triangles (side by side) merged. With `colors` (T, 3): (polygon, colour)
    pairs, a quad's the mean of its two triangles'."""
    g = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area2 = np.linalg.norm(g, axis=1)
    scale = float(np.abs(tris).max()) if len(tris) else 1.0
    flip = np.einsum("ij,ij->i", g, normals.sum(axis=1)) < 0
    tris = np.where(flip[:, None, None], tris[:, [0, 2, 1]], tris)
    g = np.where(flip[:, None], -g, g)
    keep = area2 > 1e-12 * max(scale, 1.0) ** 2
    unit = g / np.maximum(area2, 1e-300)[:, None]
    out, t, n = [], 0, len(tris)
    while t < n:
        if not keep[t]:
            t += 1
            continue
        if t + 1 < n and keep[t + 1] and float(unit[t] @ unit[t + 1]) >= COPLANAR:
            quad = _merge_quad(tris[t], tris[t + 1])
            if quad is not None:
                out.append(quad if colors is None else
                           (quad, 0.5 * (colors[t] + colors[t + 1])))
                t += 2
                continue
        out.append(tris[t] if colors is None else (tris[t], colors[t]))
        t += 1
    return out


def _group_frame(polys: list) -> tuple:
    """(centre, x, y, normal, width, height) of the box in which a mesh's emitting
    polygons (front-wound, world) lie: about their summed area vector (the largest
    polygon's normal where those cancel, as on a closed mesh), x along the largest
    polygon's first edge."""
    area_vectors = np.array([np.cross(c - c[0], np.roll(c, -1, axis=0) - c[0]).sum(axis=0) / 2
                             for c in polys])
    sizes = np.linalg.norm(area_vectors, axis=1)
    largest = int(np.argmax(sizes))
    total = area_vectors.sum(axis=0)
    normal = total if np.linalg.norm(total) > 1e-6 * sizes.sum() else area_vectors[largest]
    normal = normal / np.linalg.norm(normal)
    edge = polys[largest][1] - polys[largest][0]
    x = edge - normal * (edge @ normal)
    if np.linalg.norm(x) < 1e-9 * np.linalg.norm(edge):
        x = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    x = x / np.linalg.norm(x)
    y = np.cross(normal, x)
    corners = np.concatenate(polys)
    rel = corners - corners[0]
    u, v, h = rel @ x, rel @ y, rel @ normal
    centre = corners[0] + x * (u.min() + u.max()) / 2 + y * (v.min() + v.max()) / 2 + \
        normal * (h.min() + h.max()) / 2
    return centre, x, y, normal, float(u.max() - u.min()), float(v.max() - v.min())


def mesh_light(name: str, emitting: list, emitter: tuple = ()) -> Light:
    """The light of one placed mesh's emitting polygons, [(corners, colour, front,
    back)]: each its own polygon (wound about the face it lights from), radiance and
    faces; together one light with one shadow, an area light's over the box they lie
    in (_group_frame), which the mesh itself (`emitter`: its instance) does not cast
    into."""
    centre, x, y, normal, width, height = _group_frame([c for c, *_ in emitting])
    polys = tuple(c if front else c[::-1].copy() for c, _, front, _ in emitting)
    colours = np.array([colour for _, colour, *_ in emitting], np.float64)
    return Light(kind=POLYGON, name=name, color=colours.max(axis=0), position=centre,
                 axis=normal, x_axis=x, y_axis=y, width=width, height=height,
                 polygons=polys, polygon_colors=colours,
                 two_sided=np.array([front and back for *_, front, back in emitting]),
                 soft_falloff=False, emitter=emitter)


def _chunks(polys: list) -> list:
    """`polys` as lights of at most CHUNK polygons, those that lie together in one, each
    light's in the order of the Morton curve of their centres: the leaves of its tree of
    groups (engine/emitter_groups.py) in an order in which aligned runs of a power of
    two are blocks of the mesh. The centres are counted in cells of the polygons'
    median size along the axes of the box they lie in (_group_frame), so that a grid of
    quads is ordered by its rows and columns and its blocks are rects."""
    if len(polys) <= 1:
        return [polys] if polys else []
    corners = [c for c, *_ in polys]
    _, x, y, normal, _, _ = _group_frame(corners)
    axes = np.stack([x, y, normal])
    centres = np.array([c.mean(axis=0) for c in corners]) @ axes.T
    sizes = np.array([np.ptp(c @ axes.T, axis=0) for c in corners])
    cell = np.maximum(np.median(sizes, axis=0), 1e-9 * max(float(np.ptp(centres)), 1e-30))
    grid = np.round((centres - centres.min(axis=0)) / cell)
    if grid.max() < 1 << BITS:         # the cells themselves, each its own Morton cell
        order = np.argsort(morton_codes(grid, np.full(3, -0.5), np.full(3, (1 << BITS) - 1.5)),
                           kind="stable")
    else:
        order = morton_order(centres)
    return [[polys[i] for i in order[k:k + CHUNK]] for k in range(0, len(polys), CHUNK)]


def makes_lights(mesh) -> bool:
    """Whether a mesh's emitting faces can be lights: not a skinned, blend-shaped or
    GPU-subdivided one (its triangles are posed on the GPU)."""
    return mesh.skin is None and mesh.patches is None


def closed_sides(front: bool, back: bool) -> tuple:
    """The sides of a closed mesh's faces that are lights, of the sides its sampling asks
    for. Its back faces face its inside, which they alone light: outside, the mesh hides
    them, but it casts nothing into its own light's map. Both faces: the front; Back
    alone stays Back (its inside lit). The irradiance field takes the sides left out
    (engine/gpu/passes/irradiance.py)."""
    return front, back and not front


def instance_lights(inst, mesh, materials) -> tuple[dict, str | None]:
    """({light path: Light} of an instance's emitting polygons, a warning or None)."""
    emitting, networked = [], []
    for mat_index, first, count in mesh.ranges:
        material = materials.get(mesh.materials[mat_index])
        if material is None:
            continue
        if material.pattern is not None and material.pattern.feeds("emissiveColor"):
            # What a node network emits varies over the surface in ways its constant
            # does not say (a texture through a Mix, a ramp): not a light, rather than
            # a light of the wrong colour.
            networked.append(material.name)
            continue
        front, back = SAMPLING.get(material.emission_sampling, SAMPLING["auto"])
        if (front or back) and float(radiance(material).max()) > 0.0:
            uv = mesh.vertices[mesh.indices[first:first + count].reshape(-1, 3), 6:8]
            colors = triangle_radiance(material, uv.astype(np.float64))
            emitting.append((first, count, colors, front, back))
    why = None if not networked else \
        f"{inst.path}: the emission of {', '.join(networked)} comes from a node " \
        f"network and lights only itself (not made a light)"
    if not emitting:
        return {}, why
    if not makes_lights(mesh):
        why = "skinned or blend-shaped" if mesh.skin is not None else "subdivided on the GPU"
        return {}, f"{inst.path}: its emission lights only itself (a {why} mesh's " \
                   f"emitting faces are not made lights)"
    if closed(mesh):
        emitting = [(first, count, colors, *closed_sides(front, back))
                    for first, count, colors, front, back in emitting]
    worlds = inst.worlds if inst.worlds is not None else [inst.world]
    points = mesh.vertices[:, :3].astype(np.float64)
    normals = mesh.vertices[:, 3:6].astype(np.float64)
    lights = {}
    for w, world in enumerate(worlds):
        world = np.asarray(world, np.float64)
        p = points @ world[:3, :3].T + world[:3, 3]
        nrm = normals @ np.linalg.inv(world[:3, :3])     # the inverse transpose, row vectors
        polys = []
        for first, count, colors, front, back in emitting:
            idx = mesh.indices[first:first + count].reshape(-1, 3)
            polys += [(corners, c, front, back)
                      for corners, c in polygons(p[idx], nrm[idx], colors) if c.max() > 0.0]
        for c, chunk in enumerate(_chunks(polys)):
            path = f"{inst.path}<emission" + (f" {w}" if len(worlds) > 1 else "") + \
                (f" {c}" if len(polys) > CHUNK else "") + ">"
            lights[path] = mesh_light(f"{inst.path} emission", chunk, (inst.path, w))
    return lights, why


def _same(a: Light, b: Light) -> bool:
    return len(a.polygons) == len(b.polygons) and a.emitter == b.emitter and \
        all(np.array_equal(p, q) for p, q in zip(a.polygons, b.polygons)) and \
        all(np.array_equal(getattr(a, f), getattr(b, f)) for f in
            ("polygon_colors", "two_sided", "position", "axis", "x_axis", "width", "height"))


class Emitters:
    """The emitter lights of a Scene, kept current by sync."""

    def __init__(self):
        self.lights_of = {}       # instance path -> its light paths
        self.warnings = {}        # instance path -> why its emission lights nothing

    def sync(self, scene, changes, everything: bool):
        """Makes the lights of the instances `changes` touched (all of them when
        `everything`), adding their paths to changes.lights."""
        touched = set(scene.instances) if everything else \
            set(changes.instances) | set(changes.dropped_instances)
        if not everything and (changes.meshes or changes.materials):
            for path, inst in scene.instances.items():
                mesh = scene.meshes.get(inst.mesh_key)
                if inst.mesh_key in changes.meshes or (
                        mesh is not None and not changes.materials.isdisjoint(mesh.materials)):
                    touched.add(path)
        for path in touched:
            inst = scene.instances.get(path)
            mesh = scene.meshes.get(inst.mesh_key) if inst is not None else None
            new, warning = instance_lights(inst, mesh, scene.materials) if mesh is not None \
                else ({}, None)
            for old in self.lights_of.pop(path, ()):
                if old not in new:
                    del scene.lights[old]
                    changes.lights.add(old)
            for p, light in new.items():
                kept = scene.lights.get(p)
                if kept is None or not _same(kept, light):
                    scene.lights[p] = light
                    changes.lights.add(p)
            if new:
                self.lights_of[path] = tuple(new)
            self.warnings.pop(path, None)
            if warning:
                self.warnings[path] = warning
        if self.warnings:
            scene.warnings[WARNINGS] = list(self.warnings.values())
        else:
            scene.warnings.pop(WARNINGS, None)
