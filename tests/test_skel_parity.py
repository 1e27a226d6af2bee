"""UsdSkel parity: at every frame, UsdSkel's own skinning of the exported stage equals
Blender's evaluated vertices (max error ≤ 1e-5 × bounding-box diagonal).

Each case builds a rig with bpy and says whether the mesh must be skinned (UsdSkel)
or baked (time-sampled points, with a warning naming the object and the reason).
"""
import bpy
import numpy as np
import pytest
from mathutils import Matrix
from pxr import UsdGeom, UsdSkel

from _export_helpers import (add_armature_modifier, animate_pose, export_current,
                             make_armature, make_tube, object_paths, parity, skinned_stage,
                             weight_by_height)
from lantern.exporters import ExportOptions

TOLERANCE = 1e-5
BONES = ("Bone0", "Bone1", "Bone2")
FIGURES = {}  # case -> worst error, printed with -s


def _rig(name="Rig", bones=BONES, **kwargs):
    arm = make_armature(name, bones, **kwargs)
    tube = make_tube(name + "_Body")
    weight_by_height(tube, bones)
    return arm, tube


def _parented(arm, tube):
    """Parented to the armature (plain Object parenting) and skinned by it."""
    tube.parent = arm
    add_armature_modifier(tube, arm)
    return tube


def _gpu_parity(stage):
    """Largest |GPU-skinned − UsdSkel-skinned| over the stage's frames and skinned
    meshes, as a fraction of each mesh's bounding-box diagonal (Lantern's own
    exports on the engine's GPU path)."""
    from lantern.engine import skinned_points
    baked = skinned_stage(stage)
    worst, meshes = 0.0, set()
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    for frame in range(start, end + 1):
        for path, (points, _normals) in skinned_points(stage, frame).items():
            mesh = UsdGeom.Mesh(baked.GetPrimAtPath(path))
            cpu = np.array(mesh.GetPointsAttr().Get(frame), dtype=np.float64)
            m = np.array(mesh.ComputeLocalToWorldTransform(frame))
            cpu = cpu @ m[:3, :3] + m[3, :3]
            assert points.shape == cpu.shape, path
            diag = float(np.linalg.norm(cpu.max(0) - cpu.min(0))) or 1.0
            worst = max(worst, float(np.abs(points - cpu).max()) / diag)
            meshes.add(str(path))
    return worst, meshes


def _check(case, objects, *, skinned=(), baked=(), options=None, reason=None):
    stage, report = export_current(options)
    errors = parity(stage, objects)
    FIGURES[case] = max(errors.values())
    print(f"\n{case}: " + ", ".join(f"{k} {v:.2e}" for k, v in errors.items()))
    assert max(errors.values()) <= TOLERANCE, errors
    if skinned:
        gpu_error, gpu_meshes = _gpu_parity(stage)
        print(f"{case}: GPU skinning vs UsdSkel {gpu_error:.2e} over {len(gpu_meshes)} meshes")
        assert len(gpu_meshes) >= len(skinned), gpu_meshes
        assert gpu_error <= TOLERANCE, gpu_error
    paths = object_paths(stage)
    for ob in skinned:
        mesh = _mesh(stage, paths[ob.name])
        assert mesh.HasAPI(UsdSkel.BindingAPI), ob.name
        assert not mesh.GetAttribute("points").GetTimeSamples(), ob.name
        root = UsdSkel.Root.Find(mesh)
        assert root, f"{ob.name} is not under a SkelRoot"
    for ob in baked:
        mesh = _mesh(stage, paths[ob.name])
        assert not mesh.HasAPI(UsdSkel.BindingAPI), ob.name
        assert len(mesh.GetAttribute("points").GetTimeSamples()) == \
            bpy.context.scene.frame_end - bpy.context.scene.frame_start + 1
        assert mesh.GetAttribute("normals").GetTimeSamples()
        assert any(f"'{ob.name}'" in w and (reason is None or reason in w)
                   for w in report.warnings), report.warnings
    if not baked:
        assert not any("baked" in w for w in report.warnings), report.warnings
    return stage, report


def _mesh(stage, object_path):
    meshes = [c for c in stage.GetPrimAtPath(object_path).GetChildren() if c.IsA(UsdGeom.Mesh)]
    assert len(meshes) == 1
    return meshes[0]


# -- expressible rigs: skinned by UsdSkel ---------------------------------------------------

def test_bone_chain_with_roll(empty_scene):
    arm, tube = _rig()
    _parented(arm, tube)
    animate_pose(arm)
    stage, _ = _check("chain with roll", [tube], skinned=[tube])
    skel = UsdSkel.Skeleton(next(p for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton)))
    assert list(skel.GetJointsAttr().Get()) == ["Bone0", "Bone0/Bone1", "Bone0/Bone1/Bone2"]
    # restTransforms are the rest pose, not the current (animated) pose.
    rest = np.array(skel.GetRestTransformsAttr().Get()[1]).T
    bones = arm.data.bones
    np.testing.assert_allclose(
        rest, np.linalg.solve(np.array(bones[0].matrix_local), np.array(bones[1].matrix_local)),
        atol=1e-6)
    bind = np.array(skel.GetBindTransformsAttr().Get()[2]).T
    np.testing.assert_allclose(bind, np.array(arm.matrix_world) @ np.array(bones[2].matrix_local),
                               atol=1e-6)


def test_parity_check_sees_a_wrong_pose(empty_scene):
    arm, tube = _rig()
    _parented(arm, tube)
    animate_pose(arm)
    stage, _ = export_current()
    anim = UsdSkel.Animation(next(p for p in stage.Traverse() if p.IsA(UsdSkel.Animation)))
    rotations = anim.GetRotationsAttr()
    rotations.Set(rotations.Get(3), 4)  # frame 4 shows frame 3's rotations
    errors = parity(stage, [tube])
    assert errors[tube.name] > 100 * TOLERANCE


def test_transformed_scaled_armature(empty_scene):
    arm, tube = _rig()
    arm.location, arm.rotation_euler, arm.scale = (1, -2, 0.5), (0.3, -0.4, 1.1), (1.5, 0.7, 2.0)
    _parented(arm, tube)
    tube.matrix_parent_inverse = Matrix.Translation((0.2, 0.1, -0.3))
    animate_pose(arm)
    _check("transformed, scaled armature", [tube], skinned=[tube])


def test_unparented_mesh_with_offset(empty_scene):
    arm, tube = _rig()
    arm.location, arm.rotation_euler = (0.5, 0, 0), (0, 0, 0.6)
    tube.location, tube.rotation_euler, tube.scale = (2, 1, -1), (0.2, 0.1, 0), (1, 1.2, 0.9)
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    stage, _ = _check("unparented mesh with offset", [tube], skinned=[tube])
    # geomBindTransform differs from identity: the mesh is not where the armature is.
    binding = UsdSkel.BindingAPI(_mesh(stage, object_paths(stage)[tube.name]))
    assert not np.allclose(np.array(binding.GetGeomBindTransformAttr().Get()), np.eye(4))


def test_zero_weight_vertices_stay_put(empty_scene):
    arm = make_armature("Rig", BONES)
    tube = make_tube("Rig_Body")
    weight_by_height(tube, BONES, skip=set(range(0, 104, 5)))
    tube.vertex_groups["Bone2"].add([3], 0.00005, "REPLACE")  # under Blender's 1e-4
    add_armature_modifier(tube, arm)
    tube.parent = arm
    animate_pose(arm)
    stage, _ = _check("zero-weight vertices", [tube], skinned=[tube])
    skel = next(p for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton))
    assert list(skel.GetAttribute("lantern:jointNames").Get())[-1] == ""
    assert list(UsdSkel.Skeleton(skel).GetJointsAttr().Get())[-1] == "lantern_static"


def test_group_of_non_deform_bone_is_ignored(empty_scene):
    arm, tube = _rig()
    arm.data.bones["Bone1"].use_deform = False
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    _check("non-deform bone group", [tube], skinned=[tube])


def test_preserve_volume_is_dual_quaternion(empty_scene):
    arm, tube = _rig()
    mod = add_armature_modifier(tube, arm, preserve_volume=True)
    assert mod.use_deform_preserve_volume
    animate_pose(arm)
    stage, _ = _check("preserve volume (DQS)", [tube], skinned=[tube])
    binding = UsdSkel.BindingAPI(_mesh(stage, object_paths(stage)[tube.name]))
    assert binding.GetSkinningMethodAttr().Get() == UsdSkel.Tokens.dualQuaternion
    # Negative control: the pose is one where linear blending differs visibly.
    binding.GetSkinningMethodAttr().Set(UsdSkel.Tokens.classicLinear)
    assert parity(stage, [tube])[tube.name] > 100 * TOLERANCE


def test_bone_scale_linear(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    # Scales half precision holds exactly: UsdSkel can carry them.
    animate_pose(arm, scale=lambda f, i: (1 + 0.25 * (f % 2), 0.75, 1.5 if i == 1 else 1.0))
    _check("bone scale, linear", [tube], skinned=[tube])


def test_subsurf_before_armature(empty_scene):
    arm, tube = _rig()
    sub = tube.modifiers.new("Subsurf", "SUBSURF")
    sub.levels = 1
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    _check("subsurf before armature", [tube], skinned=[tube])


def test_mirror_before_armature(empty_scene):
    """A Mirror modifier before the armature changes the rest mesh, not the skinning."""
    arm, tube = _rig()
    for vertex in tube.data.vertices:
        vertex.co.x += 0.6  # so the mirrored half is a separate copy at -0.6
    tube.modifiers.new("Mirror", "MIRROR")
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    stage, _ = _check("mirror before armature", [tube], skinned=[tube])
    mesh = UsdGeom.Mesh(_mesh(stage, object_paths(stage)[tube.name]))
    assert len(mesh.GetPointsAttr().Get()) == 2 * len(tube.data.vertices)


def test_non_uniform_mesh_scale(empty_scene):
    arm, tube = _rig()
    _parented(arm, tube)
    tube.scale = (1.8, 0.6, 1.3)
    tube.rotation_euler = (0.0, 0.0, 0.4)
    animate_pose(arm)
    _check("non-uniform mesh scale", [tube], skinned=[tube])


@pytest.mark.parametrize("width", [6, 9, 12])
def test_many_influences(empty_scene, width):
    bones = tuple(f"B{i}" for i in range(12))
    arm = make_armature("Rig", bones, length=0.25)
    tube = make_tube("Rig_Body")
    weight_by_height(tube, bones, length=0.25, spread=width / 2)
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    stage, _ = _check(f"{width} influences", [tube], skinned=[tube])
    binding = UsdSkel.BindingAPI(_mesh(stage, object_paths(stage)[tube.name]))
    assert binding.GetJointIndicesPrimvar().GetElementSize() == \
        binding.GetJointWeightsPrimvar().GetElementSize() >= min(width, 12) - 1


def test_max_influences_trims(empty_scene):
    bones = tuple(f"B{i}" for i in range(12))
    arm = make_armature("Rig", bones, length=0.25)
    tube = make_tube("Rig_Body")
    weight_by_height(tube, bones, length=0.25, spread=5)
    add_armature_modifier(tube, arm)
    stage, _ = export_current(ExportOptions(max_influences=4))  # validation: sums are 1
    binding = UsdSkel.BindingAPI(_mesh(stage, object_paths(stage)[tube.name]))
    assert binding.GetJointIndicesPrimvar().GetElementSize() == 4


def test_copy_rotation_constraint(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    driver = bpy.data.objects.new("Driver", None)
    bpy.context.scene.collection.objects.link(driver)
    c = arm.pose.bones["Bone2"].constraints.new("COPY_ROTATION")
    c.target = driver
    animate_pose(arm)
    for f in range(1, 6):
        driver.rotation_euler = (0.2 * f, 0.1, -0.3 * f)
        driver.keyframe_insert("rotation_euler", frame=f)
    _check("copy rotation constraint", [tube], skinned=[tube])


def test_ik_chain(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    target = bpy.data.objects.new("Target", None)
    bpy.context.scene.collection.objects.link(target)
    ik = arm.pose.bones["Bone2"].constraints.new("IK")
    ik.target, ik.chain_count = target, 2
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 5
    for f in range(1, 6):
        target.location = (1.0 + 0.2 * f, 0.3, 2.0 - 0.1 * f)
        target.keyframe_insert("location", frame=f)
    _check("IK chain", [tube], skinned=[tube])


def test_two_meshes_share_a_rig(empty_scene):
    arm, tube = _rig()
    other = make_tube("Second", radius=0.5, segments=6)
    weight_by_height(other, BONES)
    other.location = (0.3, 0.4, 0)
    for ob in (tube, other):
        add_armature_modifier(ob, arm)
    tube.parent = arm
    animate_pose(arm)
    stage, _ = _check("two meshes, one rig", [tube, other], skinned=[tube, other])
    assert len([p for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton)]) == 1


def test_two_rigs(empty_scene):
    a_arm, a_tube = _rig("A")
    b_arm, b_tube = _rig("B", bones=("Hip", "Knee", "Foot"))
    b_arm.location = (3, 0, 0)
    for arm, tube in ((a_arm, a_tube), (b_arm, b_tube)):
        add_armature_modifier(tube, arm)
        animate_pose(arm)
    _check("two rigs", [a_tube, b_tube], skinned=[a_tube, b_tube])


def test_animated_armature_object(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    tube.parent = arm
    animate_pose(arm)
    for f in range(1, 6):
        arm.location = (0.3 * f, 0, 0.1 * f)
        arm.rotation_euler = (0, 0, 0.2 * f)
        arm.keyframe_insert("location", frame=f)
        arm.keyframe_insert("rotation_euler", frame=f)
    stage, _ = _check("animated armature object", [tube], skinned=[tube])
    root = stage.GetPrimAtPath(object_paths(stage)[arm.name])
    assert root.IsA(UsdSkel.Root)
    assert len(root.GetAttribute("xformOp:orient").GetTimeSamples()) == 5


def test_colliding_and_non_ascii_bone_names(empty_scene):
    names = ("Hand.L", "Hand_L", "Ärm ✋")
    arm, tube = _rig(bones=names, chain=False)
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    stage, _ = _check("colliding, non-ASCII names", [tube], skinned=[tube])
    skel = UsdSkel.Skeleton(next(p for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton)))
    joints = list(skel.GetJointsAttr().Get())
    assert len(set(joints)) == 3 and "Hand_L" in joints
    assert list(skel.GetPrim().GetAttribute("lantern:jointNames").Get()) == list(names)
    assert list(skel.GetJointNamesAttr().Get()) == list(names)


# -- shape keys ---------------------------------------------------------------------------

def _keyed(ob, armature=None):
    """Basis, A, B relative to A, C masked by a group, D muted; all animated."""
    ob.shape_key_add(name="Basis")
    rng = np.random.default_rng(3)
    keys = []
    for name in ("A", "B", "C", "D"):
        kb = ob.shape_key_add(name=name, from_mix=False)
        co = np.empty(len(kb.data) * 3, dtype=np.float32)
        kb.data.foreach_get("co", co)
        kb.data.foreach_set("co", co + rng.normal(0, 0.05, co.shape).astype(np.float32))
        keys.append(kb)
    keys[1].relative_key = keys[0]
    mask = ob.vertex_groups.new(name="Mask")
    mask.add(list(range(0, 40)), 0.6, "REPLACE")
    keys[2].vertex_group = "Mask"
    keys[3].mute = True
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 5
    for f in range(1, 6):
        for i, kb in enumerate(keys):
            kb.value = (0.2 * f + 0.1 * i) % 1.0
            kb.keyframe_insert("value", frame=f)


def test_shape_keys_without_armature(empty_scene):
    tube = make_tube("Keyed")
    tube.location = (1, 2, 3)
    _keyed(tube)
    stage, _ = _check("shape keys, no armature", [tube], skinned=[tube])
    root = stage.GetPrimAtPath(object_paths(stage)[tube.name])
    assert root.IsA(UsdSkel.Root)
    shapes = [c for c in _mesh(stage, root.GetPath()).GetChildren() if c.IsA(UsdSkel.BlendShape)]
    assert len(shapes) == 4


def test_shape_keys_with_armature(empty_scene):
    arm, tube = _rig()
    _keyed(tube)
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    _check("shape keys + armature", [tube], skinned=[tube])


# -- not expressible: baked points ---------------------------------------------------------

def test_fallback_envelopes(empty_scene):
    arm = make_armature("Rig", BONES)
    tube = make_tube("Rig_Body")
    weight_by_height(tube, BONES, skip=set(range(0, 104, 3)))
    mod = add_armature_modifier(tube, arm)
    mod.use_bone_envelopes = True
    animate_pose(arm)
    _check("fallback: envelopes", [tube], baked=[tube], reason="envelopes")


def test_fallback_two_armatures(empty_scene):
    arm, tube = _rig()
    other = make_armature("Other", BONES)
    other.location = (0.5, 0, 0)
    add_armature_modifier(tube, arm)
    add_armature_modifier(tube, other)
    animate_pose(arm)
    animate_pose(other)
    _check("fallback: two armatures", [tube], baked=[tube], reason="more than one")


def test_fallback_vertex_group_mask(empty_scene):
    arm, tube = _rig()
    mod = add_armature_modifier(tube, arm)
    mod.vertex_group = "Bone1"
    animate_pose(arm)
    _check("fallback: vertex group mask", [tube], baked=[tube], reason="vertex group")


def test_fallback_bbones(empty_scene):
    arm, tube = _rig()
    for b in arm.data.bones:
        b.bbone_segments = 4
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    _check("fallback: B-Bones", [tube], baked=[tube], reason="B-Bones")


def test_fallback_solidify_after_armature(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    tube.modifiers.new("Solidify", "SOLIDIFY").thickness = 0.05
    animate_pose(arm)
    _check("fallback: solidify after armature", [tube], baked=[tube], reason="Solidify")


def test_fallback_mesh_moves_relative_to_rig(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    for f in range(1, 6):
        tube.location = (0.1 * f, 0, 0)
        tube.keyframe_insert("location", frame=f)
    _check("fallback: mesh moves relative to rig", [tube], baked=[tube], reason="relative")


def test_fallback_armature_moves_unparented_mesh(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    for f in range(1, 6):
        arm.location = (0, 0.2 * f, 0)
        arm.keyframe_insert("location", frame=f)
    _check("fallback: armature moves, mesh not parented", [tube], baked=[tube],
           reason="relative")


def test_fallback_bone_scale_not_half_exact(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    animate_pose(arm, scale=lambda f, i: (1 + 0.013 * f, 1.0, 1.0))
    _check("fallback: bone scale not exact in half", [tube], baked=[tube],
           reason="half precision")


def test_fallback_preserve_volume_with_scaled_bones(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm, preserve_volume=True)
    animate_pose(arm, scale=lambda f, i: (1 + 0.25 * (f % 2), 1.0, 1.5 if i == 1 else 1.0))
    _check("fallback: DQS with scaled bones", [tube], baked=[tube], reason="Preserve Volume")


def test_fallback_inherit_scale_none(empty_scene):
    arm, tube = _rig()
    arm.data.bones["Bone1"].inherit_scale = "NONE"
    add_armature_modifier(tube, arm)
    animate_pose(arm, scale=lambda f, i: (1.5, 0.5, 1.0) if i == 0 else (1.0, 1.0, 1.0))
    _check("fallback: inherit scale none", [tube], baked=[tube], reason="shear")


def test_static_scene_is_unchanged_without_animation(empty_scene):
    arm, tube = _rig()
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    stage, report = export_current(ExportOptions(animation=False))
    assert not any(p.IsA(UsdSkel.Skeleton) for p in stage.Traverse())
    assert report.counts["skeletons"] == 0
