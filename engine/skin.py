"""A rig's numbers per frame, in numpy: joint matrices packed as texels, the active
blend shapes, and the bounds of the posed mesh. No USD and no GL: engine/usd/skel.py
reads bindings and poses, engine/gpu/passes/skinning.py deforms with these.

UsdSkel's convention, which the shader follows (shaders/skinning.glsl):
  blend shapes first, on the mesh's own points:  P = points + sum_s w_s * offset_s
  then P' = sum_j w_j * X_j * (G * P)   (LBS; X_j = ComputeSkinningTransforms, G =
  geomBindTransform), in skeleton space, drawn with the skeleton's local-to-world.
  DQS splits X_j = T_j R_j S_j (polar decomposition of its 3x3): the scale parts are
  blended linearly on the point, the rigid parts as dual quaternions."""
from __future__ import annotations

import numpy as np

from ..core.transforms import quaternion_multiply, quaternions_from_matrices

MAX_ATTRIBUTE_INFLUENCES = 8   # beyond this, influences come from a texture
FLAT_TEX_W = 4096              # texels per row of the flat (per-point) textures
LBS_TEXELS, DQS_TEXELS = 6, 14


def _inv_t(m3):
    det = np.linalg.det(m3)
    safe = np.where(np.abs(det) > 1e-30, 1.0, 0.0)[:, None, None]
    inv = np.linalg.inv(np.where(safe > 0, m3, np.eye(3)))
    return np.where(safe > 0, inv.transpose(0, 2, 1), m3)


def joint_texels(xforms, dqs=False) -> np.ndarray:
    """(n, 4, 4) skinning transforms -> (n, 6|14, 4) float32 texture rows, one joint
    per row: texels 0-2 the 3x4 matrix rows, 3-5 the rows of its 3x3 inverse
    transpose (normals); with dqs also 6 the rotation quaternion, 7 the dual part,
    8-10 the scale matrix rows, 11-13 the scale's inverse transpose rows."""
    n = len(xforms)
    out = np.zeros((n, DQS_TEXELS if dqs else LBS_TEXELS, 4))
    out[:, 0:3, :] = xforms[:, :3, :]
    m3 = xforms[:, :3, :3]
    out[:, 3:6, :3] = _inv_t(m3)
    if dqs:
        # Polar decomposition M3 = R S, as Gf's Factor + Orthonormalize gives it.
        U, _, Vt_ = np.linalg.svd(m3)
        R = U @ Vt_
        flip = np.linalg.det(R) < 0
        U[flip, :, 2] *= -1
        R = U @ Vt_
        S = R.transpose(0, 2, 1) @ m3
        q = quaternions_from_matrices(R)
        t = np.concatenate([xforms[:, :3, 3], np.zeros((n, 1))], 1)
        out[:, 6] = q
        out[:, 7] = 0.5 * quaternion_multiply(t, q)
        out[:, 8:11, :3] = S
        out[:, 11:14, :3] = _inv_t(S)
    return np.ascontiguousarray(out, np.float32)


def local_bounds(skin, pose, shapes, rest_lo, rest_hi):
    """Conservative AABB, in the space the mesh is drawn in, of a skinned mesh this
    frame: each used joint's current position padded by its bind-space radius (plus
    the largest blend-shape displacement) times the joint's largest scale. Assumes
    weights summing to one, as UsdSkel expects. Blend shapes alone: the rest bounds
    padded."""
    pad = 0.0
    if skin.shape_max is not None:
        pad = sum(abs(w) * float(skin.shape_max[i]) for i, w in shapes if i < len(skin.shape_max))
    if skin.joints is None or pose is None:
        return rest_lo - pad, rest_hi + pad
    xf = pose.xforms[:len(skin.joint_radius)]
    used = skin.joint_used
    m = xf[used]
    centers = np.einsum("nij,nj->ni", m[:, :3, :3], skin.joint_centers[used]) + m[:, :3, 3]
    scale = np.linalg.norm(m[:, :3, :3], axis=1).max(axis=1)
    g_scale = float(np.linalg.norm(skin.geom_bind[:3, :3], axis=0).max())
    r = ((skin.joint_radius[used] + pad * g_scale) * scale)[:, None]
    return (centers - r).min(axis=0), (centers + r).max(axis=0)


def influence_texels(joints, weights):
    """(n_points, 4g) joints and weights -> flat texels, per point g pairs of
    (4 joint indices as floats, exact below 2^24; 4 weights), as the shader reads them."""
    n, k = joints.shape
    groups = np.stack([joints.reshape(n, k // 4, 4).astype(np.float32),
                       weights.reshape(n, k // 4, 4).astype(np.float32)], axis=2)
    return groups.reshape(-1, 4)


def flat_texels(texels) -> np.ndarray:
    """(n, 4) texels -> (rows, FLAT_TEX_W, 4) float32, row-major, zero padded."""
    rows = max(1, -(-len(texels) // FLAT_TEX_W))
    data = np.zeros((rows * FLAT_TEX_W, 4), np.float32)
    data[:len(texels)] = texels
    return data.reshape(rows, FLAT_TEX_W, 4)


def incidence_texels(indices, point_of_vertex, n_points) -> np.ndarray:
    """A mesh's triangles listed per point, for normals of its deformed surface
    (shaders/skin.vert SKIN_SURFACE_NORMALS): texel p < n_points holds (first,
    count) of point p's entries; entry i, at texel n_points + i, the vertex indices of
    one of its triangles, in their winding (floats, exact below 2^24)."""
    tri = np.asarray(indices, np.int64).reshape(-1, 3)
    corner_points = np.asarray(point_of_vertex, np.int64)[tri.reshape(-1)]
    order = np.argsort(corner_points, kind="stable")
    counts = np.bincount(corner_points, minlength=n_points)
    texels = np.zeros((n_points + len(order), 4))
    texels[:n_points, 0] = np.cumsum(counts) - counts
    texels[:n_points, 1] = counts
    texels[n_points:, :3] = tri[order // 3]
    return texels


def shape_texels(skin) -> np.ndarray:
    off = skin.shape_offsets
    return flat_texels(np.concatenate([off, np.zeros((len(off), 1))], axis=1))


def active_texels(skin, shapes):
    """One texel per active sub-shape: point-offset block, normal block, weight."""
    rows = [(skin.shape_blocks[i][0], skin.shape_blocks[i][1], w, 0.0)
            for i, w in shapes if i < len(skin.shape_blocks) and max(skin.shape_blocks[i]) >= 0]
    return np.array(rows or [(-1, -1, 0, 0)], np.float32).reshape(1, -1, 4), len(rows)


def defines(skin) -> list:
    """The skinning.glsl variant of a mesh: only what it uses."""
    if skin is None:
        return []
    out = []
    if skin.shape_offsets is not None:
        out.append("SKIN_SHAPES")
    if skin.joints is not None:
        out.append("SKIN_JOINTS")
        k = skin.joints.shape[1]
        if k > MAX_ATTRIBUTE_INFLUENCES:
            out.append("SKIN_JOINTS_TEX")
        elif k > 4:
            out.append("SKIN_JOINTS8")
        if skin.method == "dqs":
            out.append("SKIN_DQS")
    return out
