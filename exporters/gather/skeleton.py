"""An armature -> SkeletonRecord: joint order, rest and bind matrices, pose channels."""
import numpy as np

from ...core.transforms import SINGULAR, affine_inverse, quaternions_from_matrices
from ..ir import SkeletonRecord

# Local pose matrices that are not translate·rotate·scale (shear, from Inherit Scale
# modes under non-uniform scale) cannot be written as SkelAnimation channels.
SHEAR_TOLERANCE = 1e-5
# SkelAnimation scales are half3: a scale half precision rounds is not exact.
HALF_TOLERANCE = 1e-6
# A matrix is written as translate · orient · scale when they recompose it this closely
# (relative to its size; Blender's matrices are float32).
TRS_TOLERANCE = 1e-6


def _matrices(collection, attr):
    """(n, 4, 4) float64 Blender matrices; foreach_get yields them column-major."""
    flat = np.empty(len(collection) * 16, dtype=np.float32)
    if len(collection):
        collection.foreach_get(attr, flat)
    return flat.reshape(-1, 4, 4).transpose(0, 2, 1).astype(np.float64)


def joint_order(bones):
    """Bone indices parents first (depth first, Blender's child order), and parent indices."""
    index = {b.name: i for i, b in enumerate(bones)}
    order = []
    # An explicit stack, not recursion: a chain of a thousand bones is a thousand deep.
    stack = [bone for bone in reversed(bones) if bone.parent is None]
    while stack:
        bone = stack.pop()
        order.append(index[bone.name])
        stack.extend(reversed(bone.children))
    position = {bone_index: j for j, bone_index in enumerate(order)}
    parents = [position[index[bones[i].parent.name]] if bones[i].parent else -1 for i in order]
    return order, parents


def gather_skeleton(arm_ob, key, world):
    """`world`: the armature's world matrix at the bind frame (the export's frame)."""
    bones = arm_ob.data.bones
    order, parents = joint_order(bones)
    rest_arm = _matrices(bones, "matrix_local")[order]  # armature space
    rest = rest_arm.copy()
    for j, p in enumerate(parents):
        if p >= 0:
            rest[j] = np.linalg.solve(rest_arm[p], rest_arm[j])
    return SkeletonRecord(key=key, name=arm_ob.data.name,
                          joint_names=[bones[i].name for i in order], parents=parents,
                          bind=world @ rest_arm, rest=rest, rest_armature=rest_arm)


def shape_host(key, name, world):
    """A joint-less rig for a mesh with shape keys only: just the static joint."""
    return SkeletonRecord(key=key, name=name, joint_names=[], parents=[],
                          bind=np.zeros((0, 4, 4)), rest=np.zeros((0, 4, 4)),
                          rest_armature=np.zeros((0, 4, 4)), static_world=world)


def pose_matrices(arm_eval, pose_order):
    """Armature-space pose matrices of the evaluated pose, in joint order."""
    return _matrices(arm_eval.pose.bones, "matrix")[pose_order]


def pose_index(arm_ob, joint_names):
    names = [pb.name for pb in arm_ob.pose.bones]
    position = {n: i for i, n in enumerate(names)}
    return np.array([position[n] for n in joint_names], dtype=np.int64)


def relative_matrix(parent, child):
    """parent⁻¹ · child for (..., 4, 4) world matrices, finite under a zero-scale parent."""
    return affine_inverse(parent) @ child


def local_matrices(poses, parents):
    """(T, J, 4, 4) armature-space poses -> parent-relative matrices."""
    parents = np.asarray(parents, dtype=np.int64)
    has_parent = parents >= 0
    local = poses.copy()
    if has_parent.any():
        inverse = affine_inverse(poses[:, parents[has_parent]])
        local[:, has_parent] = inverse @ poses[:, has_parent]
    return local


def _complete_rotation(r, zero):
    """Fills the columns of `r` whose scale is zero (`zero`, (..., 3)) so that r is a
    rotation: a zero scale says nothing about the rotation of that axis."""
    r = r.copy()
    count = zero.sum(-1)
    one = count == 1
    if one.any():  # the missing axis is the cross product of the other two
        sub, z = r[one], zero[one]
        for i in range(3):
            rows = z[:, i]
            j, k = (i + 1) % 3, (i + 2) % 3
            sub[rows, :, i] = np.cross(sub[rows, :, j], sub[rows, :, k])
        r[one] = sub
    two = count == 2
    if two.any():  # keep the one known axis, complete it to a right-handed basis
        sub, z = r[two], zero[two]
        for i in range(3):
            rows = ~z[:, i]
            if not rows.any():
                continue
            j, k = (i + 1) % 3, (i + 2) % 3
            axis = sub[rows, :, i]
            helper = np.eye(3)[np.argmin(np.abs(axis), axis=1)]
            u = np.cross(helper, axis)
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            sub[rows, :, j], sub[rows, :, k] = u, np.cross(axis, u)
        r[two] = sub
    r[count == 3] = np.eye(3)
    return r


def decompose(local):
    """(T, J, 4, 4) -> translations, quaternions (x, y, z, w), scales, and the worst
    shear and half-precision errors (0 when the channels are exact). A zero scale
    keeps an identity rotation for that axis; the matrix is still recomposed exactly."""
    t = local[..., :3, 3]
    a = local[..., :3, :3]
    s = np.linalg.norm(a, axis=-2)
    size = np.maximum(s.max(axis=-1, keepdims=True), 1e-300)
    zero = s <= SINGULAR * size
    s = np.where(zero, 0.0, s)
    flip = np.linalg.det(a) < 0
    s[..., 0] = np.where(flip, -s[..., 0], s[..., 0])
    r = a / np.where(zero, 1.0, s)[..., None, :]
    r = np.where(zero[..., None, :], 0.0, r)
    if zero.any():
        r = _complete_rotation(r, zero)
    shear = np.abs(np.swapaxes(r, -1, -2) @ r - np.eye(3)).max(initial=0.0)
    q = quaternions_from_matrices(r)
    # Neighbouring frames on the same hemisphere, so interpolation takes the short way.
    for f in range(1, len(q)):
        q[f] *= np.where((q[f] * q[f - 1]).sum(-1) < 0, -1.0, 1.0)[..., None]
    half = np.abs(s.astype(np.float16).astype(np.float64) - s)
    half_error = (half / np.maximum(np.abs(s), 1e-12)).max(initial=0.0)
    return t, q, s, shear, half_error


def rotation_matrices(q):
    """(..., 4) unit quaternions (x, y, z, w) -> (..., 3, 3)."""
    x, y, z, w = np.moveaxis(np.asarray(q, np.float64), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)


def recompose(t, q, s):
    """translate · rotate · scale -> (..., 4, 4) matrices (Blender's convention)."""
    m = np.zeros(np.shape(t)[:-1] + (4, 4))
    m[..., :3, :3] = rotation_matrices(q) * np.asarray(s)[..., None, :]
    m[..., :3, 3] = t
    m[..., 3, 3] = 1.0
    return m


def trs_parts(matrices):
    """(T, 4, 4) matrices -> (TRS, exact): exact[i] when translate · orient · scale
    recompose matrix i within TRS_TOLERANCE (False: it shears). Quaternions of
    neighbouring rows share a hemisphere, so slerp between them goes the short way."""
    from ..ir import TRS
    m = np.asarray(matrices, np.float64)
    t, q, s, _, _ = decompose(m[:, None])
    t, q, s = t[:, 0], q[:, 0], s[:, 0]
    size = np.maximum(np.abs(m[:, :3, :3]).max(axis=(1, 2), initial=0.0), 1.0)
    error = np.abs(recompose(t, q, s)[:, :3, :3] - m[:, :3, :3]).max(axis=(1, 2), initial=0.0)
    return TRS(translations=t, rotations=q, scales=s), error / size <= TRS_TOLERANCE


def trs(matrices):
    """TRS of (T, 4, 4) matrices when every one is exactly translate · orient · scale,
    else None (the matrices must be written as they are)."""
    parts, exact = trs_parts(matrices)
    return parts if exact.all() else None


def bone_scale_error(poses, rest_armature, deform):
    """Largest deviation from a rigid pose·rest⁻¹ over deform bones (Blender's DQS
    handles scale differently from UsdSkel's)."""
    if not deform.any():
        return 0.0
    chan = poses[:, deform, :3, :3] @ np.linalg.inv(rest_armature[deform, :3, :3])
    return float(np.abs(np.swapaxes(chan, -1, -2) @ chan - np.eye(3)).max(initial=0.0))
