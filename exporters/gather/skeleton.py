"""An armature -> SkeletonRecord: joint order, rest and bind matrices, pose channels."""
import numpy as np

from ...core.transforms import affine_inverse, quaternions_from_matrices
from ..ir import SkeletonRecord

# Local pose matrices that are not translate·rotate·scale (shear, from Inherit Scale
# modes under non-uniform scale) cannot be written as SkelAnimation channels.
SHEAR_TOLERANCE = 1e-5
# SkelAnimation scales are half3: a scale half precision rounds is not exact.
HALF_TOLERANCE = 1e-6


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

    def visit(bone):
        order.append(index[bone.name])
        for child in bone.children:
            visit(child)
    for bone in bones:
        if bone.parent is None:
            visit(bone)
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


def local_matrices(poses, parents):
    """(T, J, 4, 4) armature-space poses -> parent-relative matrices."""
    parents = np.asarray(parents, dtype=np.int64)
    has_parent = parents >= 0
    local = poses.copy()
    if has_parent.any():
        inverse = affine_inverse(poses[:, parents[has_parent]])
        local[:, has_parent] = inverse @ poses[:, has_parent]
    return local


def decompose(local):
    """(T, J, 4, 4) -> translations, quaternions (x, y, z, w), scales, and the worst
    shear and half-precision errors (0 when the channels are exact)."""
    t = local[..., :3, 3]
    a = local[..., :3, :3]
    s = np.linalg.norm(a, axis=-2)
    flip = np.linalg.det(a) < 0
    s[..., 0] = np.where(flip, -s[..., 0], s[..., 0])
    r = a / np.where(s == 0, 1.0, s)[..., None, :]
    shear = np.abs(np.swapaxes(r, -1, -2) @ r - np.eye(3)).max(initial=0.0)
    q = quaternions_from_matrices(r)
    # Neighbouring frames on the same hemisphere, so interpolation takes the short way.
    for f in range(1, len(q)):
        q[f] *= np.where((q[f] * q[f - 1]).sum(-1) < 0, -1.0, 1.0)[:, None]
    half = np.abs(s.astype(np.float16).astype(np.float64) - s)
    half_error = (half / np.maximum(np.abs(s), 1e-12)).max(initial=0.0)
    return t, q, s, shear, half_error


def bone_scale_error(poses, rest_armature, deform):
    """Largest deviation from a rigid pose·rest⁻¹ over deform bones (Blender's DQS
    handles scale differently from UsdSkel's)."""
    if not deform.any():
        return 0.0
    chan = poses[:, deform, :3, :3] @ np.linalg.inv(rest_armature[deform, :3, :3])
    return float(np.abs(np.swapaxes(chan, -1, -2) @ chan - np.eye(3)).max(initial=0.0))
