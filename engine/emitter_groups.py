"""Groups of an emissive mesh's polygons, so that a pixel far from a group shades it as
one rect (shaders/lights.glsl area_light walks them): the implicit complete binary tree
over a polygon light's polygons in their order (node i has children 2i+1 and 2i+2, the
leaves the polygons, padded to a power of two), as the light tree (engine/light_tree.py)
is over point lights. The polygons of a mesh light lie together in that order: a mesh's
own (a grid's rows), or the Morton curve of their centres (engine/emitters.py).

A group of coplanar polygons, all lighting from the same faces, stands for them as the
rect that bounds them in their plane, of their mean radiance over it (their power kept):
LTC shades it as exactly as one polygon. Where the polygons fill the rect with one
radiance (a panel of quads, or any part of it that is a rect) it is exact at any
distance. Otherwise it differs from them by D(x), the radiance they have less that
rect's mean, of zero integral: the irradiance at p facing n, f(x) = (n_l.u)(n.u)/|u|^4,
u = x - p, smooth while the whole rect is above p's horizon, differs by at most
    |grad f(c)| |m1| + max|f''| / 2 * r^2 * integral |D|
  <= 6 |m1| / dmin^3 + 19 r^2 integral|D| / dmin^4            (per channel)
(c the rect's centre, r its half diagonal, dmin = |c - p| - r, m1 = the first moment of
D about c = P (mu - c), P the power and mu the power's centroid; |grad f| <= 6 / |u|^3,
the Hessian's norm <= 38 / |u|^4). A pixel shades the group as its rect where that bound
is within RenderSettings.light_error of the rect's own irradiance, else its parts; at
error 0 only groups that are exact. Glossy light from a group is the rect's LTC share:
approximate where the group is not exact, not bounded (as the light tree's groups)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FLAT = 1e-6          # relative: coplanar, one radiance, filling the rect


@dataclass
class Groups:
    """The tree's inner nodes (leaves - 1 of them; none for one polygon): each node's rect
    `corners` (4, 3) wound about `front`, mean `radiance`, `both` (lights from both
    faces), `area` of the rect, `moment` |m1| and `deviation` integral |D| per channel,
    `radius` (half diagonal), `count` of polygons and `flat` (whether it may stand for
    them: coplanar, one sidedness)."""
    corners: np.ndarray
    radiance: np.ndarray
    front: np.ndarray
    both: np.ndarray
    area: np.ndarray
    moment: np.ndarray
    deviation: np.ndarray
    radius: np.ndarray
    count: np.ndarray
    flat: np.ndarray


def leaves(n: int) -> int:
    """The padded leaf count of a tree over n polygons."""
    return 1 << max(int(np.ceil(np.log2(max(n, 1)))), 0)


def _area_centroid(corners: np.ndarray) -> tuple:
    """(area vector, centroid) of a planar polygon, by its fan of triangles."""
    a, b, c = corners[0], corners[1:-1], corners[2:]
    tri = np.cross(b - a, c - a) / 2
    sizes = np.linalg.norm(tri, axis=1)
    centre = (a + b + c) / 3
    total = sizes.sum()
    centroid = (sizes[:, None] * centre).sum(axis=0) / total if total > 0 else corners.mean(axis=0)
    return tri.sum(axis=0), centroid


def build(polygons, colours, two_sided) -> Groups:
    """The groups of a polygon light's polygons (world corners wound about the face they
    light from), radiances and two-sidedness."""
    n = len(polygons)
    inner = leaves(n) - 1
    g = Groups(np.zeros((inner, 4, 3)), np.zeros((inner, 3)), np.zeros((inner, 3)),
               np.zeros(inner, bool), np.zeros(inner), np.zeros((inner, 3)),
               np.zeros((inner, 3)), np.zeros(inner), np.zeros(inner, int), np.zeros(inner, bool))
    if inner == 0:
        return g
    vectors, centroids = zip(*(_area_centroid(np.asarray(c, np.float64)) for c in polygons))
    vectors, centroids = np.array(vectors), np.array(centroids)
    areas = np.linalg.norm(vectors, axis=1)
    normals = vectors / np.maximum(areas, 1e-300)[:, None]
    colours = np.asarray(colours, np.float64)
    two_sided = np.asarray(two_sided, bool)
    for i in range(inner):
        depth = int(np.floor(np.log2(i + 1)))
        span = leaves(n) >> depth
        first = (i + 1 - (1 << depth)) * span
        members = np.arange(first, min(first + span, n))
        g.count[i] = len(members)
        if len(members):
            _fill(g, i, [np.asarray(polygons[k], np.float64) for k in members], areas[members],
                  normals[members], centroids[members], colours[members], two_sided[members])
    return g


def _fill(g: Groups, i: int, polys, areas, normals, centroids, colours, two_sided):
    """Node i of g from its polygons."""
    front = normals[0]
    corners = np.concatenate(polys)
    extent = np.ptp(corners, axis=0).max()
    g.front[i], g.both[i] = front, two_sided[0]
    g.flat[i] = bool((normals @ front > 1 - FLAT).all() and two_sided.all() == two_sided.any()
                     and (np.abs((corners - corners[0]) @ front) <= FLAT * extent).all())
    if not g.flat[i]:
        return
    edge = polys[0][1] - polys[0][0]
    x = edge - front * (edge @ front)
    x /= np.linalg.norm(x)
    y = np.cross(front, x)
    u, v = (corners - corners[0]) @ x, (corners - corners[0]) @ y
    o = corners[0] + x * u.min() + y * v.min()
    w, h = u.max() - u.min(), v.max() - v.min()
    g.corners[i] = [o, o + x * w, o + x * w + y * h, o + y * h]
    rect = w * h
    if rect <= 0:
        g.flat[i] = False
        return
    power = (colours * areas[:, None]).sum(axis=0)
    mean = power / rect
    centre = o + (x * w + y * h) / 2
    first = ((colours * areas[:, None])[:, :, None] * (centroids - centre)[:, None, :]).sum(axis=0)
    moment = np.linalg.norm(first, axis=1)
    deviation = (np.abs(colours - mean) * areas[:, None]).sum(axis=0) + \
        mean * max(rect - areas.sum(), 0.0)
    radius = 0.5 * float(np.hypot(w, h))
    scale = np.maximum(power, 1e-300)
    g.moment[i] = np.where(moment <= FLAT * scale * radius, 0.0, moment)
    g.deviation[i] = np.where(deviation <= FLAT * scale, 0.0, deviation)
    g.radiance[i], g.area[i], g.radius[i] = mean, rect, radius


def error_bound(g: Groups, i: int, p, n) -> np.ndarray | None:
    """The bound on how far group i's rect is from its polygons' irradiance at p facing
    n, per channel, as shaders/lights.glsl group_stands computes it; None where the
    group may not stand for them there (not coplanar, too near, its rect not wholly
    above the horizon)."""
    p, n = np.asarray(p, float), np.asarray(n, float)
    d = float(np.linalg.norm(g.corners[i].mean(axis=0) - p))
    dmin = d - g.radius[i]
    if not g.flat[i] or dmin <= 0 or ((g.corners[i] - p) @ n).min() <= 0:
        return None
    return (6.0 * g.moment[i] + 19.0 * g.radius[i] ** 2 * g.deviation[i] / dmin) / dmin ** 3
