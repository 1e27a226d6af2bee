"""The light tree: many point lights as a binary tree of groups, so that a pixel far
from a group shades it as one light within a stated error (clustered lighting,
engine/gpu/passes/clustered.py; shaders/light_tree.glsl reads the nodes).

Which lights: point lights without shadows (the many small lights of a scene). Spots,
area lights, suns and shadowed lights are shaded one by one.

The tree is complete and implicit (node i has children 2i+1 and 2i+2; the leaves, one
light each, padded to a power of two with empty ones, follow the lights in Morton order
so that each node holds lights that lie together). Each node keeps its lights' total
diffuse and specular power, their power-weighted centroid mu, covariance M, bounding
radius r about mu and box.

A group stands for its lights at its centroid (lightcuts' representative, Walter et
al. 2005), with the second-order term of the irradiance's Taylor series about mu
added: for the irradiance of a unit light g(u) = (n.u) / |u|^3, u = x - p, the mean of
g over the group is g(mu - p) + tr(H M) / 2 + O(r^3). The first-order term vanishes at
the power-weighted centroid. Measured over random groups of 2 to 64 lights (boxes,
plates and lines, all above the horizon: the shader opens a group that is not) and
random surfaces, seen from at least MIN_GROUP_RADII of their radii, the corrected
group is within 0.94 (r/d)^3 / cos of its own irradiance (cos: of the surface to the
centroid; tests/test_light_tree.py), and within 1.49 over 20,000 groups that include
rotated grids of lights, to r/d 0.8 (2026-11-28). Lights of different colours add a first-order
term per channel, within 3 |mu_c - mu| / (n.u) of the group's irradiance (spread: the
largest |mu_c - mu|). So a group's error on a surface is at most
    bound = P (ERROR_CONSTANT r^3 / d^2 + 3 spread) / d^3        (P: its power)
and a pixel shades a group as one light where either
  - bound <= error P (n.u) / d^3: within `error` of the group's own light, or
  - bound <= error T, T a lower bound of the pixel's light from all the tree's lights,
    and the group at least MIN_GROUP_RADII radii away: its error is small against the
    pixel's light (lightcuts' test, which bounds each group's error against the
    pixel's total, not their sum; near a dense field of lights, where every light is
    within reach of every pixel, it keeps a pixel's walk to about a hundred nodes).
The pixel finds T first (shaders/light_tree.glsl tree_lower_bound): a coarse cut, each
group at least MIN_GROUP_RADII radii away and above the horizon counted as its power
times its lights' least n.u over its box's greatest distance cubed, every other light
on its own. A cluster of pixels (passes/light_cull.py) lists a group whole where some pixel
of it may use it (list_distance: the nearer of group_distance, where the first test
holds for a surface facing the group, and MIN_GROUP_RADII radii); a pixel opens it
where its own surface fails both tests. The specular lobe of a group is a sphere light
of radius r at mu (the lobe widened by r / 2d, Karis 2013): approximate, not bounded
(docs/rendering.md "Many lights").

error 0: no groups; every light is shaded on its own where its volume reaches
(engine/lighting.py volume_radius), as the light volumes shade it. With error > 0 a
light has no volume: far from it, it is part of a group, and its tail is never cut."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.lights import POINT
from ..core.morton import morton_order
from .view import split_double

ERROR_CONSTANT = 1.5         # above the worst measured, 1.49, of the corrected group's error
MIN_GROUP_RADII = 2.0        # the nearest a group stands for its lights (r / d <= 0.5,
                             # as far as its error was measured)
NODE_TEXELS = 8              # vec4s per node: shaders/light_tree.glsl
NEVER = 3.0e38               # a distance no pixel reaches


def in_tree(light) -> bool:
    """Whether a light is shaded through the tree (else one by one)."""
    return light.kind == POINT and not light.shadow


def group_distance(radius, spread, error: float) -> np.ndarray:
    """The least distance d at which a group of this radius and colour spread can stand
    for its lights (the pixel test, ERROR_CONSTANT r^3 / d^2 + 3 spread <= error n.u, at
    its best: n.u = d); NEVER at error 0."""
    radius, spread = np.asarray(radius, float), np.asarray(spread, float)
    if error <= 0:
        return np.full(radius.shape, NEVER)
    lo = np.zeros(radius.shape)
    hi = np.maximum(radius * (ERROR_CONSTANT / error) ** (1.0 / 3.0) + 3.0 * spread / error,
                    1e-30) * 2.0
    for _ in range(60):                     # bisection: the test grows with d
        mid = 0.5 * (lo + hi)
        ok = ERROR_CONSTANT * radius ** 3 / np.maximum(mid * mid, 1e-300) + 3.0 * spread \
            <= error * mid
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    return np.minimum(hi, NEVER)


def list_distance(radius, spread, error: float) -> np.ndarray:
    """The least distance at which some pixel may shade a group as one light: where
    it is within `error` of its own light (group_distance), or from MIN_GROUP_RADII
    radii, where it may be small against the pixel's light; NEVER at error 0."""
    near = group_distance(radius, spread, error)
    return near if error <= 0 else np.minimum(near, MIN_GROUP_RADII * np.asarray(radius, float))


@dataclass
class LightTree:
    """A built tree: `nodes` (n_nodes, NODE_TEXELS, 4) float32 as the shader reads them,
    `leaves` (the padded leaf count), `rows` (the light table row of each tree light),
    and, for tests and the CPU, the node values in float64."""
    nodes: np.ndarray
    leaves: int
    rows: np.ndarray
    centroid: np.ndarray          # (n_nodes, 3)
    radius: np.ndarray            # (n_nodes,)
    list_distance: np.ndarray     # (n_nodes,): a cluster lists a group from this
    diffuse: np.ndarray           # (n_nodes, 3) power
    specular: np.ndarray          # (n_nodes, 3)
    covariance: np.ndarray        # (n_nodes, 3, 3)
    count: np.ndarray             # (n_nodes,) lights


def build(lights, rows, ranges, error: float) -> LightTree | None:
    """The tree of `lights` (scene Light records, in_tree), whose light-table rows are
    `rows` and volume radii `ranges` (used at error 0), for the error bound `error`.
    None without lights."""
    if not lights:
        return None
    n = len(lights)
    pos = np.array([light.position for light in lights], np.float64)
    colour = np.array([light.color for light in lights], np.float64)
    pd = colour * np.array([light.diffuse for light in lights])[:, None]
    ps = colour * np.array([light.specular for light in lights])[:, None]
    reach = np.asarray(ranges, np.float64) if error <= 0 else np.full(n, NEVER)
    order = morton_order(pos)
    leaves = 1 << max(int(np.ceil(np.log2(n))), 0)
    pad = leaves - n
    take = lambda a, fill=0.0: np.concatenate(  # noqa: E731
        [a[order], np.full((pad,) + a.shape[1:], fill, a.dtype)])
    real = np.r_[np.ones(n, bool), np.zeros(pad, bool)]
    origin = pos.mean(axis=0)                      # moments about it: no cancellation
    x = take(pos - origin)
    power = np.concatenate([take(pd), take(ps)], axis=1)       # (leaves, 6) channels
    weight = power.sum(axis=1)
    real = np.r_[np.ones(n, bool), np.zeros(pad, bool)]

    # The leaves' sums, then each level's from the level below (children 2i+1, 2i+2 of
    # node i lie side by side): total power per channel, its first moments, the
    # weight's first and second moments, the box, and bounds on the radius and reach.
    n_nodes = 2 * leaves - 1
    chan = np.zeros((n_nodes, 6))
    first_c = np.zeros((n_nodes, 6, 3))
    w = np.zeros(n_nodes)
    first = np.zeros((n_nodes, 3))
    second = np.zeros((n_nodes, 3, 3))
    lo = np.full((n_nodes, 3), np.inf)
    hi = np.full((n_nodes, 3), -np.inf)
    count = np.zeros(n_nodes)
    leaf = slice(leaves - 1, n_nodes)
    chan[leaf] = power
    first_c[leaf] = power[:, :, None] * x[:, None, :]
    w[leaf] = weight
    first[leaf] = weight[:, None] * x
    second[leaf] = weight[:, None, None] * x[:, :, None] * x[:, None, :]
    lo[leaf] = np.where(real[:, None], x, np.inf)
    hi[leaf] = np.where(real[:, None], x, -np.inf)
    count[leaf] = real
    level = leaves // 2
    while level >= 1:
        parents = np.arange(level - 1, 2 * level - 1)
        a, b = 2 * parents + 1, 2 * parents + 2
        for arr in (chan, first_c, w, first, second, count):
            arr[parents] = arr[a] + arr[b]
        lo[parents] = np.minimum(lo[a], lo[b])
        hi[parents] = np.maximum(hi[a], hi[b])
        level //= 2
    safe = np.maximum(w, 1e-300)
    centroid = first / safe[:, None]           # a node of black lights: its box's middle
    dark = (w <= 0) & (count > 0)
    centroid[dark] = 0.5 * (lo[dark] + hi[dark])
    cov = second / safe[:, None, None] - centroid[:, :, None] * centroid[:, None, :]
    cov[w <= 0] = 0.0
    mu_c = first_c / np.maximum(chan, 1e-300)[:, :, None]
    spread = np.where(chan > 0, np.linalg.norm(mu_c - centroid[:, None, :], axis=2), 0.0).max(axis=1)
    empty = count == 0
    lo[empty] = hi[empty] = centroid[empty]
    # The radius about the centroid: the farthest box corner, or the children's radii
    # moved to it, whichever is smaller (both bound it); the same for the reach.
    corner = np.linalg.norm(np.maximum(np.abs(lo - centroid), np.abs(hi - centroid)), axis=1)
    radius = np.zeros(n_nodes)
    reach_of = np.zeros(n_nodes)
    reach_of[leaf] = np.where(real, take(reach), 0.0)
    level = leaves // 2
    while level >= 1:
        parents = np.arange(level - 1, 2 * level - 1)
        kids = np.stack([2 * parents + 1, 2 * parents + 2])
        moved = np.linalg.norm(centroid[kids] - centroid[parents][None], axis=2)
        live = count[kids] > 0
        radius[parents] = np.minimum(
            np.where(live, radius[kids] + moved, 0.0).max(axis=0), corner[parents])
        reach_of[parents] = np.where(live, reach_of[kids] + moved, 0.0).max(axis=0)
        level //= 2
    box = np.stack([lo - centroid, hi - centroid], axis=1)
    leaf_rows = take(np.asarray(rows, np.float64), -1.0)

    group = list_distance(radius, spread, error)
    group[leaves - 1:] = 0.0                       # a leaf is its light

    world = centroid + origin
    hi, lo = split_double(world)
    nodes = np.zeros((n_nodes, NODE_TEXELS, 4), np.float32)
    nodes[:, 0, :3], nodes[:, 0, 3] = hi, group
    nodes[:, 1, :3], nodes[:, 1, 3] = lo, radius
    nodes[:, 2, :3], nodes[:, 2, 3] = chan[:, :3], count
    nodes[:, 3, :3], nodes[:, 3, 3] = chan[:, 3:], np.minimum(reach_of, NEVER)
    nodes[:, 4] = cov[:, [0, 1, 2, 0], [0, 1, 2, 1]]
    nodes[:, 5, :2] = cov[:, [0, 1], [2, 2]]
    nodes[leaves - 1:, 5, 3] = leaf_rows
    nodes[:leaves - 1, 5, 3] = -1.0
    nodes[:, 6, :3], nodes[:, 6, 3] = box[:, 0], spread
    nodes[:, 7, :3] = box[:, 1]
    return LightTree(nodes, leaves, np.asarray(rows)[order], world, radius, group,
                     chan[:, :3], chan[:, 3:], cov, count)


def group_irradiance(power, centroid, covariance, p, n) -> np.ndarray:
    """What a group of `power` (W/sr, per channel) at `centroid` with `covariance`
    sends onto a surface at p facing n, per unit area: g(mu - p) P plus the
    second-order term (shaders/light_tree.glsl group_irradiance computes the same)."""
    u = np.asarray(centroid, float) - np.asarray(p, float)
    n = np.asarray(n, float)
    d2 = float(u @ u)
    d = d2 ** 0.5
    nu = float(n @ u)
    M = np.asarray(covariance, float)
    g = nu / (d2 * d)
    corr = (-3.0 * float(n @ M @ u) - 1.5 * nu * np.trace(M)) / (d2 * d2 * d) + \
        7.5 * nu * float(u @ M @ u) / (d2 * d2 * d2 * d)
    return np.asarray(power, float) * (g + corr)
