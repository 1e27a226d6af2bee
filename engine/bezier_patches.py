"""An all-quad Catmull-Clark mesh -> one bicubic Bezier patch per quad, for the GPU's
tessellation stages (Loop and Schaefer's ACC-1, "Approximating Catmull-Clark
Subdivision Surfaces with Bicubic Patches", 2008).

Where a quad's four corners are regular (smooth with four edges, or on a straight
crease or boundary), its patch is exactly the limit surface: the uniform B-spline patch
of its ring, in Bezier form. Around an extraordinary vertex it approximates the limit
surface; the distance is measured in docs/subdivision.md. Every control point on an
edge is computed once for that edge and every corner once for its vertex, so two patches
that share an edge share its curve: the surface has no cracks at any tessellation.

A quad's 16 control points are row-major, B[v][u]: u runs from corner 0 to corner 1,
v from corner 0 to corner 3 (counter-clockwise corners).
"""
import numpy as np

from .subdivision import Cage, limit_points, refine, vertex_rules

# Corner i of a quad -> its control point, and the two edge points beside it:
# (corner, along edge i towards corner i+1, along edge i-1 towards corner i-1).
_CORNER = ((0, 0), (0, 3), (3, 3), (3, 0))
_INTERIOR = ((1, 1), (1, 2), (2, 2), (2, 1))
_NEXT = ((0, 1), (1, 3), (3, 2), (2, 0))   # on edge i, next to corner i
_PREV = ((1, 0), (0, 2), (2, 3), (3, 1))   # on edge i-1, next to corner i


def bezier_patches(c: Cage) -> np.ndarray:
    """(F, 16, 3) control points of the quads of `c` (refined once at least); (F, 16, d)
    for points of width d."""
    if (c.counts != 4).any():
        raise ValueError("bezier_patches needs an all-quad mesh (refine once first)")
    quads = c.indices.reshape(-1, 4)
    n_f = len(quads)
    p = c.points
    d = p.shape[1]          # 3, or any width: every control point is linear in the points
    rule, edges, sharp_edge = vertex_rules(c)
    valence = np.bincount(edges.ravel(), minlength=len(p)).astype(np.float64)
    # Off the smooth rule, the ring's weights are the regular ones: exact on a straight
    # crease or boundary (the B-spline with its ring mirrored), approximate elsewhere.
    n = np.where(rule == 0, valence, 4.0)

    q = [quads[:, i] for i in range(4)]
    interior = np.empty((n_f, 4, d))
    for i in range(4):
        ni = n[q[i]][:, None]
        interior[:, i] = (ni * p[q[i]] + 2 * p[q[(i + 1) % 4]] + 2 * p[q[(i + 3) % 4]]
                          + p[q[(i + 2) % 4]]) / (ni + 5)

    # Each directed edge (corner i -> i+1) and its twin (b -> a) in the face across it.
    a, b = quads.reshape(-1), quads[:, [1, 2, 3, 0]].reshape(-1)
    n_p = np.int64(len(p))
    sharp = sharp_edge[_find(edges[:, 0] * n_p + edges[:, 1],
                             np.minimum(a, b) * n_p + np.maximum(a, b))]
    twin = _find(a * n_p + b, b * n_p + a)
    sharp |= twin < 0
    # Corner k (face k // 4) and the next corner of its face: interior points beside
    # an edge's two ends, on this side and (through the twin) on the other.
    by_corner = interior.reshape(-1, d)
    k = np.arange(len(a))
    other = np.where(twin < 0, 0, twin)

    def following(k):
        return k - k % 4 + (k + 1) % 4
    near_a = np.where(sharp[:, None], (2 * p[a] + p[b]) / 3,
                      0.5 * (by_corner[k] + by_corner[following(other)]))
    near_b = np.where(sharp[:, None], (p[a] + 2 * p[b]) / 3,
                      0.5 * (by_corner[following(k)] + by_corner[other]))
    near_a, near_b = near_a.reshape(n_f, 4, d), near_b.reshape(n_f, 4, d)

    limit = limit_points(c)
    out = np.empty((n_f, 4, 4, d))
    for i in range(4):
        out[:, _CORNER[i][0], _CORNER[i][1]] = limit[q[i]]
        out[:, _INTERIOR[i][0], _INTERIOR[i][1]] = interior[:, i]
        out[:, _NEXT[i][0], _NEXT[i][1]] = near_a[:, i]
        out[:, _PREV[i][0], _PREV[i][1]] = near_b[:, (i + 3) % 4]
    return out.reshape(n_f, 16, d)


def _find(keys, wanted):
    """Index of each wanted key in `keys` (unique where found), -1 where absent."""
    order = np.argsort(keys, kind="stable")
    at = np.searchsorted(keys[order], wanted).clip(0, len(keys) - 1)
    found = keys[order][at] == wanted
    return np.where(found, order[at], -1)


def _bernstein(t):
    t = np.asarray(t, np.float64)
    s = 1 - t
    return np.stack([s ** 3, 3 * s * s * t, 3 * s * t * t, t ** 3], axis=-1)


def evaluate(patches: np.ndarray, u, v) -> np.ndarray:
    """Points of each patch at the parameters (u, v) (arrays of one shape, or scalars):
    (F, *shape, d)."""
    bu, bv = _bernstein(u), _bernstein(v)
    grid = patches.reshape(len(patches), 4, 4, -1)
    return np.einsum("...j,...i,fjic->f...c", bv, bu, grid)


def patch_stencils(base: Cage, levels: int, block: int = 256):
    """The control points of `bezier_patches(refine(base, levels))` as weighted sums of
    the cage's points, for cages that move after they are read (skinned): CSR arrays
    (indptr (16F + 1,), point indices, weights), so that control point k is
    sum(weights[j] * points[indices[j]] for j in indptr[k]:indptr[k + 1]). The rules are
    linear in the points, so the weights are the pipeline applied to the identity, a
    block of columns at a time."""
    n = len(base.points)
    rows, cols, vals = [], [], []
    for start in range(0, n, block):
        basis = np.zeros((n, min(block, n - start)))
        basis[np.arange(start, start + basis.shape[1]), np.arange(basis.shape[1])] = 1.0
        unit = Cage(basis, base.counts, base.indices, base.edges, base.edge_sharpness,
                    base.vertex_sharpness, base.corners_sharp, base.corner_edge)
        weights = bezier_patches(refine(unit, levels)).reshape(-1, basis.shape[1])
        r, k = np.nonzero(weights)
        rows.append(r)
        cols.append(k + start)
        vals.append(weights[r, k])
    rows, cols, vals = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    order = np.lexsort((cols, rows))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=len(weights)))])
    return indptr.astype(np.int64), cols[order].astype(np.int64), vals[order]
