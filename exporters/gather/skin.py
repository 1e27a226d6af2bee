"""Which meshes UsdSkel can deform exactly as Blender does, and their skin weights.

Blender's Armature modifier (vertex groups, linear or dual-quaternion blending) is a
UsdSkel skin: each vertex moves by Σ wᵢ·poseᵢ·restᵢ⁻¹ with the weights of the groups
naming *deform* bones, divided by their sum; a vertex whose sum is ≤ 1e-4 stays where
it is. Anything else that moves points is written as baked points instead (`reason`).
"""
from dataclasses import dataclass, field

import numpy as np

# Blender's armature deform leaves a vertex alone when its weight sum is not above this.
MIN_CONTRIBUTION = 1e-4


@dataclass
class MeshRig:
    """How one mesh object is deformed."""
    armature: object | None = None       # the original armature object, or None
    modifier: object | None = None       # its Armature modifier
    shape_keys: bool = False             # relative shape keys to write as blend shapes
    reason: str | None = None            # why UsdSkel cannot express it: bake the points
    disabled: list = field(default_factory=list)  # modifiers switched off to get the rest mesh
    rest_from_data: bool = False         # the rest mesh is the mesh data (live exports)


def animated(id_data):
    ad = id_data.animation_data if id_data is not None else None
    return ad is not None and (ad.action is not None or len(ad.drivers) > 0)


def _active_modifiers(ob):
    return [m for m in ob.modifiers if m.show_viewport]


def _uses_envelopes(ob, arm_ob, deform_groups):
    """Envelopes change the result only for bones multiplying their groups by the
    envelope, or for vertices with no deform weight at all."""
    if any(b.use_deform and b.use_envelope_multiply for b in arm_ob.data.bones):
        return True
    totals = vertex_weight_totals(ob.data, deform_groups)
    return bool((totals <= MIN_CONTRIBUTION).any())


def classify(ob, exported, cage=None):
    """MeshRig for a mesh object; None when nothing deforms it over time (a plain mesh).
    `exported`: names of the objects being written. `cage`: a trailing Subdivision
    Surface modifier written as the cage's rules (the renderer subdivides after the
    skinning, as Blender does after the armature), so it may follow the Armature."""
    mods = _active_modifiers(ob)
    arms = [m for m in mods if m.type == "ARMATURE" and m.object is not None]
    key = ob.data.shape_keys
    has_keys = key is not None and len(key.key_blocks) > 1
    if ob.parent is not None and ob.parent_type == "ARMATURE":
        return MeshRig(reason="parented to its armature with Armature Deform "
                              "(a virtual modifier); use an Armature modifier")
    if not arms:
        if not has_keys or not animated(key):
            return None
        if not key.use_relative:
            return MeshRig(reason="absolute shape keys")
        if mods:
            return MeshRig(reason=f"animated shape keys under the modifier '{mods[0].name}'")
        if ob.show_only_shape_key:
            return MeshRig(reason="Shape Key Lock is on")
        return MeshRig(shape_keys=True)

    mod = arms[0]
    arm_ob = mod.object
    rig = MeshRig(armature=arm_ob, modifier=mod, shape_keys=has_keys)
    position = mods.index(mod)
    deform = {b.name for b in arm_ob.data.bones if b.use_deform}
    deform_groups = {g.index for g in ob.vertex_groups if g.name in deform}
    if len(arms) > 1:
        rig.reason = "more than one Armature modifier"
    elif arm_ob.name_full not in exported:
        rig.reason = f"its armature '{arm_ob.name}' is not exported"
    elif mod.vertex_group:
        rig.reason = "the Armature modifier is masked by a vertex group"
    elif mod.use_multi_modifier:
        rig.reason = "the Armature modifier uses Multi Modifier"
    elif not mod.use_vertex_groups:
        rig.reason = "the Armature modifier does not use vertex groups"
    elif any(b.use_deform and b.bbone_segments > 1 for b in arm_ob.data.bones):
        rig.reason = "B-Bones (segments > 1)"
    elif mod.use_bone_envelopes and _uses_envelopes(ob, arm_ob, deform_groups):
        rig.reason = "bone envelopes"
    elif position + 1 < len(mods) and mods[position + 1:] != [cage]:
        rig.reason = f"the modifier '{mods[position + 1].name}' follows the Armature modifier"
    elif has_keys and position > 0:
        rig.reason = "shape keys with modifiers before the Armature modifier"
    elif has_keys and not key.use_relative:
        rig.reason = "absolute shape keys"
    elif has_keys and ob.show_only_shape_key:
        rig.reason = "Shape Key Lock is on"
    else:
        rig.disabled = [mod]
    return rig


def group_entries(mesh):
    """Flat (vertex, group, weight) arrays of every vertex group assignment."""
    # bpy has no bulk access to vertex groups: read each vertex's groups once.
    groups = [v.groups for v in mesh.vertices]
    counts = np.fromiter(map(len, groups), dtype=np.int64, count=len(groups))
    elements = [g for vertex_groups in groups for g in vertex_groups]
    group = np.fromiter((g.group for g in elements), dtype=np.int64, count=len(elements))
    weight = np.fromiter((g.weight for g in elements), dtype=np.float64, count=len(elements))
    vertex = np.repeat(np.arange(len(groups)), counts)
    return vertex, group, weight


def vertex_weight_totals(mesh, deform_groups):
    vertex, group, weight = group_entries(mesh)
    keep = np.isin(group, list(deform_groups)) & (weight > 0)
    return np.bincount(vertex[keep], weights=weight[keep], minlength=len(mesh.vertices))


def skin_weights(ob, entries, n, joint_of_bone, static_joint):
    """(N, k) joint indices and weights (normalised, heaviest first, k = the most
    influences any vertex has); vertices Blender leaves alone get `static_joint`.
    `entries`: group_entries of the rest mesh; `joint_of_bone`: deform bone name ->
    joint index."""
    vertex, group, weight = entries
    size = max([g.index for g in ob.vertex_groups] + [int(group.max(initial=-1))]) + 1
    group_joint = np.full(size, -1)
    for g in ob.vertex_groups:
        group_joint[g.index] = joint_of_bone.get(g.name, -1)
    joint = group_joint[group]
    keep = (joint >= 0) & (weight > 0)
    vertex, joint, weight = vertex[keep], joint[keep], weight[keep]
    total = np.bincount(vertex, weights=weight, minlength=n)
    static = total <= MIN_CONTRIBUTION
    moving = ~static[vertex]
    vertex, joint, weight = vertex[moving], joint[moving], weight[moving]

    per_vertex = np.bincount(vertex, minlength=n)
    width = max(int(per_vertex.max(initial=0)), 1)
    order = np.lexsort((joint, -weight, vertex))  # heaviest first, ties by joint: deterministic
    vertex, joint, weight = vertex[order], joint[order], weight[order]
    slot = np.arange(len(vertex)) - np.repeat(np.cumsum(per_vertex) - per_vertex, per_vertex)
    indices = np.zeros((n, width), dtype=np.int32)
    weights = np.zeros((n, width), dtype=np.float64)
    indices[vertex, slot] = joint
    weights[vertex, slot] = weight / total[vertex]
    indices[static, 0] = static_joint
    weights[static, 0] = 1.0
    return indices, weights.astype(np.float32)
