"""Polygons -> triangles, without ever fanning a concave polygon.

Triangles and quads whose 0-2 diagonal lies inside them (every convex quad, as Blender
splits them) take a vectorized path; every other polygon is projected onto its best-fit
(Newell) plane and cut by mapbox-earcut, which handles concave, collinear and keyhole
("holed") rings. Each triangle is wound like its polygon. Degenerate polygons (fewer
than three corners, zero area) give fewer or zero-area triangles, never an exception.
"""
from __future__ import annotations

import mapbox_earcut
import numpy as np

from .transforms import cross


def _newell(p):
    """(..., K, 3) polygon corners -> (..., 3) Newell normals (twice the vector area)."""
    q = np.concatenate([p[..., 1:, :], p[..., :1, :]], axis=-2)   # the next corner
    return np.stack([((p[..., 1] - q[..., 1]) * (p[..., 2] + q[..., 2])).sum(-1),
                     ((p[..., 2] - q[..., 2]) * (p[..., 0] + q[..., 0])).sum(-1),
                     ((p[..., 0] - q[..., 0]) * (p[..., 1] + q[..., 1])).sum(-1)], axis=-1)


def _plane_basis(normal, corners):
    """Orthonormal (u, v) with u × v along `normal`; for a zero normal (collinear or
    coincident corners) a plane containing the corners' longest extent."""
    length = np.linalg.norm(normal)
    if length > 0 and np.isfinite(length):
        n = normal / length
    else:
        extent = corners.max(axis=0) - corners.min(axis=0)
        axis = np.zeros(3)
        axis[int(np.argmin(extent))] = 1.0
        n = axis
    helper = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = np.cross(helper, n)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _earcut(corners):
    """(K, 3) corners of one polygon -> (T, 3) local corner indices, wound like it."""
    origin = corners.mean(axis=0)        # local coordinates keep precision far away
    local = corners - origin
    u, v = _plane_basis(_newell(local), local)
    flat = np.stack([local @ u, local @ v], axis=1)
    if not np.isfinite(flat).all():
        return np.zeros((0, 3), np.int64)
    tris = mapbox_earcut.triangulate_float64(flat, np.array([len(flat)], np.uint32))
    tris = np.asarray(tris, np.int64).reshape(-1, 3)
    a, b, c = flat[tris[:, 0]], flat[tris[:, 1]], flat[tris[:, 2]]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    flip = area < 0                       # (u, v) makes the polygon counter-clockwise
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return tris


def triangulate(points, counts, indices):
    """points (N, 3), counts (F,) corners per face, indices (C,) point per corner ->
    (corners (T, 3) int64 positions into `indices`, face (T,) int64), in face order."""
    points = np.asarray(points, np.float64).reshape(-1, 3)
    counts = np.asarray(counts, np.int64).reshape(-1)
    indices = np.asarray(indices, np.int64).reshape(-1)
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]) if len(counts) else counts
    faces = np.arange(len(counts))
    pieces = []                           # (face, corners (k, 3))

    tri = faces[counts == 3]
    if len(tri):
        o = offsets[tri]
        pieces.append((tri, np.stack([o, o + 1, o + 2], axis=1)))

    quad = faces[counts == 4]
    split = np.zeros(0, np.int64)
    if len(quad):
        o = offsets[quad]
        c = o[:, None] + np.arange(4)
        p = points[indices[c]]
        p = p - p[:, :1]
        n = _newell(p)
        first = np.einsum("ij,ij->i", cross(p[:, 1], p[:, 2]), n)
        second = np.einsum("ij,ij->i", cross(p[:, 2], p[:, 3]), n)
        good = (first > 0) & (second > 0)   # the 0-2 diagonal is inside the quad
        q = quad[good]
        qc = c[good]
        if len(q):
            both = np.stack([qc[:, [0, 1, 2]], qc[:, [0, 2, 3]]], axis=1)
            pieces.append((np.repeat(q, 2), both.reshape(-1, 3)))
        split = quad[~good]

    rest = np.concatenate([split, faces[counts > 4]])
    for f in rest:
        o, k = offsets[f], counts[f]
        local = _earcut(points[indices[o:o + k]])
        if len(local):
            pieces.append((np.full(len(local), f), local + o))

    if not pieces:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    face = np.concatenate([f for f, _ in pieces])
    corners = np.concatenate([c for _, c in pieces])
    order = np.argsort(face, kind="stable")   # face order; within a face, as produced
    return corners[order].astype(np.int64), face[order].astype(np.int64)
