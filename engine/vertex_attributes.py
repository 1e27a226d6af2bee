"""Vertex attributes derived from a triangulated mesh, in numpy: smooth normals,
tangents, Blender's Generated coordinates, and the indexing of triangle corners into
vertices (engine/usd/mesh.py build_mesh uses them)."""
from __future__ import annotations

import numpy as np

from ..core.transforms import cross


def generated_coordinates(rest):
    """Blender's Generated texture coordinates of points: their place in the bounding
    box of the rest points, [0, 1] on each axis (the mesh's auto texture space; an axis
    of no extent has size 1, as Blender gives it)."""
    if not len(rest):
        return np.zeros((0, 3))
    lo, hi = rest.min(axis=0), rest.max(axis=0)
    half = (hi - lo) / 2.0
    half[half == 0.0] = 1.0
    return (rest - (lo + hi) / 2.0) / (2.0 * half) + 0.5


def index_corners(soup, keys, n_keys):
    """Triangle corners with one key (a face corner, or a point) share one vertex:
    (vertices, uint32 indices, the corner each vertex was taken from). Every corner
    with a key holds the same values, so any one of them will do."""
    first = np.full(n_keys, -1, np.int64)
    first[keys] = np.arange(len(keys))
    used = np.nonzero(first >= 0)[0]
    vertex_of_key = np.zeros(n_keys, np.int64)
    vertex_of_key[used] = np.arange(len(used))
    taken = first[used]
    return (np.ascontiguousarray(soup[taken], np.float32),
            vertex_of_key[keys].astype(np.uint32), taken)


def smooth_normals(pts, idx, corners):
    tri = idx[corners].reshape(-1, 3)
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    fn = cross(b - a, c - a)  # area-weighted
    acc = np.zeros_like(pts)
    for j in range(3):
        np.add.at(acc, tri[:, j], fn)
    n = acc / np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-30)
    return n[tri.reshape(-1)]


def compute_tangents(P, N, UV, point_of_corner):
    """Per-triangle tangents from UVs, accumulated per point, Gram-Schmidt against
    each corner's normal; w = handedness of the UV frame."""
    p = P.reshape(-1, 3, 3)
    uv = UV.reshape(-1, 3, 2)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-20, 1.0 / np.where(det == 0, 1, det), 0.0)[:, None]
    t = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    b = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    n_pts = int(point_of_corner.max()) + 1
    tacc, bacc = np.zeros((n_pts, 3)), np.zeros((n_pts, 3))
    np.add.at(tacc, point_of_corner, np.repeat(t, 3, axis=0))
    np.add.at(bacc, point_of_corner, np.repeat(b, 3, axis=0))
    tc, bc = tacc[point_of_corner], bacc[point_of_corner]
    tc = tc - N * np.sum(N * tc, axis=1, keepdims=True)
    tc /= np.maximum(np.linalg.norm(tc, axis=1, keepdims=True), 1e-30)
    w = np.where(np.sum(cross(N, tc) * bc, axis=1) < 0, -1.0, 1.0)
    return np.concatenate([tc, w[:, None]], axis=1)
