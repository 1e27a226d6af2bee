"""Matrices, quaternions and boxes, in numpy's column-vector convention (p' = M @ p).

One implementation of each: the exporter's rig decomposition and the engine's dual
quaternion skinning share the quaternion, the engine's culling, shadow fitting and
default view share the boxes, and cameras and shadow views share look_at."""
from __future__ import annotations

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of (..., 3) arrays, the same arithmetic without its axis handling,
    which costs more than the products on one small mesh's arrays."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def quaternions_from_matrices(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) proper rotation matrices -> (..., 4) unit quaternions (x, y, z, w),
    for the exporter's SkelAnimation rotations and the engine's dual quaternions.
    Shepperd's method: pivot on the largest of w, x, y, z, so no branch divides by a
    small number."""
    m = np.asarray(r, np.float64).reshape(-1, 3, 3)
    q = np.empty((len(m), 4))
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cases = np.argmax(np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1), axis=1)
    for case in range(4):
        s = cases == case
        if not np.any(s):
            continue
        a = m[s]
        if case == 0:
            t = np.sqrt(np.maximum(1.0 + tr[s], 1e-300)) * 2
            q[s] = np.stack([(a[:, 2, 1] - a[:, 1, 2]) / t, (a[:, 0, 2] - a[:, 2, 0]) / t,
                             (a[:, 1, 0] - a[:, 0, 1]) / t, 0.25 * t], axis=1)
        else:
            i = case - 1
            j, k = (i + 1) % 3, (i + 2) % 3
            t = np.sqrt(np.maximum(1.0 + a[:, i, i] - a[:, j, j] - a[:, k, k], 1e-300)) * 2
            out = np.empty((len(a), 4))
            out[:, i] = 0.25 * t
            out[:, j] = (a[:, j, i] + a[:, i, j]) / t
            out[:, k] = (a[:, k, i] + a[:, i, k]) / t
            out[:, 3] = (a[:, k, j] - a[:, j, k]) / t
            q[s] = out
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q.reshape(np.shape(r)[:-2] + (4,))


def quaternion_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (n, 4) quaternions (x, y, z, w)."""
    ax, ay, az, aw = np.asarray(a).T
    bx, by, bz, bw = np.asarray(b).T
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], 1)


SINGULAR = 1e-12   # |det| below this times the matrix's scale cubed: singular


def affine_inverse(m: np.ndarray) -> np.ndarray:
    """Inverse of (..., 4, 4) affine matrices by the 3x3 adjugate: numpy's batched
    LAPACK inverse costs microseconds per matrix, which dominates a crowd's export. A
    singular matrix (a zero or degenerate scale) gets its pseudo-inverse: finite, and
    exact wherever the matrices it is composed with collapse the same way."""
    a = m[..., :3, :3]
    c0 = np.cross(a[..., 1, :], a[..., 2, :])
    c1 = np.cross(a[..., 2, :], a[..., 0, :])
    c2 = np.cross(a[..., 0, :], a[..., 1, :])
    det = np.sum(a[..., 0, :] * c0, axis=-1)
    size = np.abs(a).max(axis=(-2, -1), initial=0.0)
    singular = np.abs(det) <= SINGULAR * np.maximum(size, 1e-300) ** 3
    safe = np.where(singular, 1.0, det)
    inv3 = np.stack([c0, c1, c2], axis=-1) / safe[..., None, None]
    if singular.any():
        inv3[singular] = np.linalg.pinv(a[singular])
    out = np.zeros_like(m)
    out[..., :3, :3] = inv3
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", inv3, m[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def normal_matrix(m: np.ndarray) -> np.ndarray:
    """The inverse transposes of (..., 4, 4) or (..., 3, 3) matrices' upper 3x3s, which
    carry normals: the cofactor matrix over the determinant, without a LAPACK call
    (numpy's costs microseconds a matrix, milliseconds on a loaded machine where its
    threads wait, and the skinning pass asks each frame). A singular matrix (a
    flattened object) keeps its own 3x3 rather than dividing by zero."""
    a = np.asarray(m, np.float64)[..., :3, :3]
    cof = np.stack([np.cross(a[..., 1, :], a[..., 2, :]),
                    np.cross(a[..., 2, :], a[..., 0, :]),
                    np.cross(a[..., 0, :], a[..., 1, :])], axis=-2)
    det = np.sum(a[..., 0, :] * cof[..., 0, :], axis=-1)
    ok = np.abs(det) > 1e-30
    return np.where(ok[..., None, None], cof / np.where(ok, det, 1.0)[..., None, None], a)


def look_at(eye, target, up) -> np.ndarray:
    """The world matrix of a camera at `eye` looking at `target` (its view matrix is
    the inverse): -Z forward, +Y towards `up`. With `up` along the view any
    perpendicular will do."""
    eye = np.asarray(eye, np.float64)
    fwd = np.asarray(target, np.float64) - eye
    fwd /= np.linalg.norm(fwd)
    side = np.cross(fwd, up)
    if np.linalg.norm(side) < 1e-6:
        side = np.cross(fwd, [1.0, 0.0, 0.0] if abs(fwd[0]) < 0.9 else [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    upv = np.cross(side, fwd)
    world = np.eye(4)
    world[:3, 0], world[:3, 1], world[:3, 2], world[:3, 3] = side, upv, -fwd, eye
    return world


def frustum(left, right, bottom, top, near, far) -> np.ndarray:
    """OpenGL's perspective projection (glFrustum)."""
    l, r, b, t, n, f = left, right, bottom, top, near, far
    return np.array([
        [2 * n / (r - l), 0, (r + l) / (r - l), 0],
        [0, 2 * n / (t - b), (t + b) / (t - b), 0],
        [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)],
        [0, 0, -1, 0]], dtype=np.float64)


def ortho(left, right, bottom, top, near, far) -> np.ndarray:
    """OpenGL's orthographic projection (glOrtho)."""
    l, r, b, t, n, f = left, right, bottom, top, near, far
    return np.array([
        [2 / (r - l), 0, 0, -(r + l) / (r - l)],
        [0, 2 / (t - b), 0, -(t + b) / (t - b)],
        [0, 0, -2 / (f - n), -(f + n) / (f - n)],
        [0, 0, 0, 1]], dtype=np.float64)


def aabb_corners(lo, hi) -> np.ndarray:
    """The 8 corners of a box, (8, 3)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (lo[2], hi[2])])


def transform_aabbs(lo: np.ndarray, hi: np.ndarray, m: np.ndarray):
    """The axis-aligned boxes around (n, 3) boxes carried by (n, 4, 4) affine
    matrices: the centres move, the half extents go through |M3| (Arvo's bound)."""
    c = (lo + hi) * 0.5
    e = (hi - lo) * 0.5
    m3 = m[:, :3, :3]
    wc = np.einsum("nij,nj->ni", m3, c) + m[:, :3, 3]
    we = np.einsum("nij,nj->ni", np.abs(m3), e)
    return wc - we, wc + we
