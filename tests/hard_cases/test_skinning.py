"""Skinning, export side: UsdSkel's skinning of the exported stage matches Blender's
evaluated mesh within 1e-5 of the bounding-box diagonal, every frame, at the extremes:
a bone scaled to zero, 200 and 1,000 bones, extreme weights, dual quaternions near
179 degrees, sheared chains (baked, exactly), non-uniform scale normals."""
import numpy as np
import pytest

BOUND = 1e-5


def _rig(bones, rings=13, **kwargs):
    from _export_helpers import (add_armature_modifier, make_armature, make_tube,
                                 weight_by_height)
    arm = make_armature("Rig", bones, **kwargs)
    tube = make_tube("Body", height=3.0 * len(bones) / 3, rings=rings)
    weight_by_height(tube, bones)
    tube.parent = arm
    return arm, tube, add_armature_modifier(tube, arm)


def _parity(objects, options=None):
    from _export_helpers import export_current, parity
    stage, report = export_current(options)
    return max(parity(stage, objects).values()), stage, report


def _skinned(stage, ob):
    from pxr import UsdGeom, UsdSkel
    from _export_helpers import object_paths
    prim = stage.GetPrimAtPath(object_paths(stage)[ob.name])
    mesh = next(c for c in prim.GetChildren() if c.IsA(UsdGeom.Mesh))
    return mesh.HasAPI(UsdSkel.BindingAPI)


def _animation_finite(stage):
    from pxr import UsdSkel
    for prim in stage.Traverse():
        if prim.IsA(UsdSkel.Animation):
            anim = UsdSkel.Animation(prim)
            for attr in (anim.GetTranslationsAttr(), anim.GetRotationsAttr(), anim.GetScalesAttr()):
                for t in attr.GetTimeSamples() or [None]:
                    value = attr.Get(t) if t is not None else attr.Get()
                    assert np.isfinite(np.array(value, dtype=np.float64)).all(), attr.GetName()


@pytest.mark.parametrize("axes", ["all", "one"])
def test_zero_scale_bone(empty_scene, axes, hard_case):
    import bpy
    arm, tube, _ = _rig(("Bone0", "Bone1", "Bone2"))
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 5
    bone = arm.pose.bones["Bone1"]
    for f, s in ((1, 1.0), (3, 0.0), (5, 1.0)):
        bone.scale = (s, s, s) if axes == "all" else (1.0, s, 1.0)
        bone.keyframe_insert("scale", frame=f)
        bone.rotation_mode = "XYZ"
        bone.rotation_euler = (0.2 * f, 0, 0.1 * f)
        bone.keyframe_insert("rotation_euler", frame=f)
    scene.frame_set(1)
    error, stage, report = _parity([tube])
    _animation_finite(stage)
    mentions = [w for w in report.warnings if "'Bone1'" in w]
    assert len(mentions) == 1 and "zero scale" in mentions[0], report.warnings
    assert _skinned(stage, tube), "expressible: not baked"
    hard_case(f"zero-scale bone ({axes} axes) vs Blender / diag", error, BOUND)


@pytest.mark.parametrize("count", [200, 1000])
def test_many_bones(empty_scene, count, hard_case):
    import bpy
    from _export_helpers import animate_pose
    bones = [f"B{i}" for i in range(count)]
    arm, tube, _ = _rig(bones, rings=count // 10 + 2, length=3.0 / count)
    animate_pose(arm, frames=range(1, 3))
    error, stage, _ = _parity([tube])
    assert _skinned(stage, tube)
    assert bpy.context.scene.frame_end == 2
    hard_case(f"{count} bones vs Blender / diag", error, BOUND)


def test_extreme_weights(empty_scene, hard_case):
    from _export_helpers import animate_pose
    arm, tube, _ = _rig(("Bone0", "Bone1", "Bone2"))
    rng = np.random.default_rng(5)
    for v in tube.data.vertices:
        for g in tube.vertex_groups:
            g.add([v.index], float(rng.choice([1e-6, 1e-3, 0.999999, 1.0, 0.5])), "REPLACE")
    animate_pose(arm)
    error, stage, _ = _parity([tube])
    hard_case("extreme weights (1e-6 … 1) vs Blender / diag", error, BOUND)


def test_dual_quaternions_near_179_degrees(empty_scene, hard_case):
    import bpy
    arm, tube, modifier = _rig(("Bone0", "Bone1", "Bone2"))
    modifier.use_deform_preserve_volume = True
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    for f, angle in ((1, 0.0), (2, 178.0), (3, 179.0)):
        for name in ("Bone1", "Bone2"):
            bone = arm.pose.bones[name]
            bone.rotation_mode = "XYZ"
            bone.rotation_euler = (np.radians(angle), 0, 0)
            bone.keyframe_insert("rotation_euler", frame=f)
    scene.frame_set(1)
    error, stage, _ = _parity([tube])
    assert _skinned(stage, tube)
    hard_case("dual quaternions at 178–179° vs Blender / diag", error, BOUND)


def test_sheared_chain_is_baked_exactly(empty_scene, hard_case):
    import bpy
    from _export_helpers import animate_pose
    arm, tube, _ = _rig(("Bone0", "Bone1", "Bone2"))
    for name in ("Bone1", "Bone2"):
        arm.data.bones[name].inherit_scale = "ALIGNED"
    animate_pose(arm, scale=lambda f, i: (1.0, 1.0 + 0.3 * f * (i == 0), 1.0))
    error, stage, report = _parity([tube])
    assert not _skinned(stage, tube)
    assert any("'Body'" in w and "baked" in w for w in report.warnings), report.warnings
    hard_case("sheared bone chain (baked) vs Blender / diag", error, BOUND)
    assert bpy.context.scene.objects["Body"]


def test_non_uniform_scale_normals(empty_scene, hard_case):
    """Object-space normals through the inverse transpose of a non-uniform world
    matrix equal Blender's normals of the mesh in world space."""
    import bpy
    from pxr import UsdGeom
    from _export_helpers import export_current, make_tube, object_paths
    tube = make_tube("Squashed")
    tube.scale = (3.0, 0.2, 1.0)
    tube.rotation_euler = (0.3, 0.2, 0.1)
    stage, _ = export_current()
    prim = stage.GetPrimAtPath(object_paths(stage)["Squashed"])
    mesh = UsdGeom.Mesh(next(c for c in prim.GetChildren() if c.IsA(UsdGeom.Mesh)))
    normals = np.array(mesh.GetNormalsAttr().Get(), np.float64)
    world = np.array(mesh.ComputeLocalToWorldTransform(0.0)).T[:3, :3]
    got = normals @ np.linalg.inv(world)  # (M⁻ᵀ n)ᵀ = nᵀ M⁻¹
    got /= np.linalg.norm(got, axis=1, keepdims=True)
    copy = tube.data.copy()
    copy.transform(tube.matrix_world)
    copy.update()
    want = np.array([v.normal for v in copy.vertices]) if mesh.GetNormalsInterpolation() == "vertex" \
        else np.array([n.vector for n in copy.corner_normals])
    hard_case("non-uniform scale normals vs Blender's world-space normals",
              np.abs(got - want).max(), 1e-5)
    assert bpy.data.meshes.remove(copy) is None
