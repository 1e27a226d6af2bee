"""The ray tracer's reference: closest hits of rays against triangles in world space,
in float64 with numpy, independent of the trees and of the shaders. Every ray meets
every triangle, through bounding spheres that only ever let a hit through: each ray
against each group of GROUP triangles that lie together (halves by the median, axis
after axis), then against each triangle of the groups it passes, then Moller and
Trumbore's test on the triangles whose sphere it passes."""
import numpy as np

BLOCK = 1024                 # rays a block
GROUP = 32                   # triangles a group


def closest_hits(triangles, origins, directions):
    """(t (n,), triangle (n,), margin (n,), second t (n,)) of rays against triangles
    (T, 3, 3): the nearest hit at t > 0 (t -1, triangle -1: none), the hit point's
    smallest barycentric weight (how near an edge it is) and the next hit's t."""
    tri = np.asarray(triangles, np.float64)
    o = np.asarray(origins, np.float64)
    d = np.asarray(directions, np.float64)
    n = len(o)
    centre, radius = _spheres(tri)
    members = _groups(centre)                                    # (G, GROUP), -1 padded
    corners = tri[np.where(members >= 0, members, members[:, :1])].reshape(len(members), -1, 3)
    g_centre, g_radius = _spheres(corners)
    best_t, best_tri = np.full(n, -1.0), np.full(n, -1, np.int64)
    margin, second = np.zeros(n), np.full(n, np.inf)
    for start in range(0, n, BLOCK):
        ob, db = o[start:start + BLOCK], d[start:start + BLOCK]
        dn = db / np.linalg.norm(db, axis=1, keepdims=True)
        gi, ri = np.nonzero(_passes(g_centre, g_radius, ob, dn))
        ti = members[gi].ravel()
        ri = np.repeat(ri, GROUP)
        keep = ti >= 0
        ti, ri = ti[keep], ri[keep]
        keep = _passes_pairs(centre[ti], radius[ti], ob[ri], dn[ri])
        ti, ri = ti[keep], ri[keep]
        t, u, v = moller_trumbore(tri[ti], ob[ri], db[ri])
        hit = t > 0
        ti, ri, t, u, v = ti[hit], ri[hit] + start, t[hit], u[hit], v[hit]
        order = np.lexsort((ti, t, ri))                         # by ray, then t, then triangle
        ti, ri, t, u, v = ti[order], ri[order], t[order], u[order], v[order]
        first = np.r_[True, ri[1:] != ri[:-1]]
        best_t[ri[first]], best_tri[ri[first]] = t[first], ti[first]
        margin[ri[first]] = np.minimum(np.minimum(u, v), 1 - u - v)[first]
        following = np.r_[False, first[:-1]] & ~first          # each ray's second hit
        second[ri[following]] = t[following]
    return best_t, best_tri, margin, second


def _spheres(points):
    """(centre, radius) of spheres around each row of points (k, m, 3): the box's
    centre, the farthest point's distance, widened a little for rounding."""
    centre = 0.5 * (points.min(axis=1) + points.max(axis=1))
    radius = np.linalg.norm(points - centre[:, None], axis=2).max(axis=1)
    return centre, radius * (1 + 1e-9) + 1e-9


def _groups(centre):
    """(G, GROUP) triangle indices, -1 padded: halves by the median along x, y, z in
    turn, until a group holds at most GROUP."""
    order, bounds = np.arange(len(centre)), [(0, len(centre))]
    axis = 0
    while max(b - a for a, b in bounds) > GROUP:
        halves = []
        for a, b in bounds:
            if b - a <= GROUP:
                halves.append((a, b))
                continue
            part = order[a:b][np.argsort(centre[order[a:b], axis], kind="stable")]
            order[a:b] = part
            halves += [(a, (a + b) // 2), ((a + b) // 2, b)]
        bounds, axis = halves, (axis + 1) % 3
    out = np.full((len(bounds), GROUP), -1, np.int64)
    for i, (a, b) in enumerate(bounds):
        out[i, :b - a] = order[a:b]
    return out


def _passes(centre, radius, o, dn):
    """(k, B) whether each ray (origin o, unit direction dn) meets each sphere ahead."""
    along = centre @ dn.T - (o * dn).sum(axis=1)                 # (c - o) . dn
    dist2 = (centre * centre).sum(axis=1)[:, None] - 2.0 * (centre @ o.T) + (o * o).sum(axis=1)
    return (dist2 - along * along <= (radius * radius)[:, None] * (1 + 1e-9) + 1e-12) & \
        (along >= -radius[:, None])


def _passes_pairs(centre, radius, o, dn):
    """Whether each ray meets its sphere ahead, pairwise."""
    rel = centre - o
    along = (rel * dn).sum(axis=1)
    dist2 = (rel * rel).sum(axis=1)
    return (dist2 - along * along <= radius * radius * (1 + 1e-9) + 1e-12) & (along >= -radius)


def moller_trumbore(tri, o, d):
    """(t, u, v) of rays against triangles, pairwise; t nan where they miss."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = (e1 * p).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - tri[:, 0]
        u = (s * p).sum(axis=1) * inv
        q = np.cross(s, e1)
        v = (d * q).sum(axis=1) * inv
        t = (e2 * q).sum(axis=1) * inv
    inside = (u >= 0) & (v >= 0) & (u + v <= 1) & (det != 0)
    return np.where(inside, t, np.nan), u, v
