"""skel_errors: the UsdSkel checks UsdValidation misses, on hand-broken stages, and
deterministic output."""
import numpy as np
from pxr import Usd, UsdGeom, UsdSkel, Vt

from _export_helpers import (add_armature_modifier, animate_pose, export_current,
                             make_armature, make_tube, weight_by_height)
from lantern.exporters.validate import skel_errors


def _stage():
    stage = Usd.Stage.CreateInMemory()
    UsdSkel.Root.Define(stage, "/Root")
    skel = UsdSkel.Skeleton.Define(stage, "/Root/Skel")
    skel.CreateJointsAttr(["A", "A/B"])
    skel.CreateJointNamesAttr(["A", "B"])
    eye = Vt.Matrix4dArray.FromNumpy(np.stack([np.eye(4)] * 2))
    skel.CreateBindTransformsAttr(eye)
    skel.CreateRestTransformsAttr(eye)
    anim = UsdSkel.Animation.Define(stage, "/Root/Skel/Anim")
    anim.CreateJointsAttr(["A", "A/B"])
    anim.CreateTranslationsAttr(Vt.Vec3fArray(2))
    anim.CreateRotationsAttr(Vt.QuatfArray(2))
    anim.CreateScalesAttr(Vt.Vec3hArray(2))
    mesh = UsdGeom.Mesh.Define(stage, "/Root/Mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray(3))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateJointIndicesPrimvar(False, 2).Set([0, 1, 1, 0, 0, 0])
    binding.CreateJointWeightsPrimvar(False, 2).Set([0.5, 0.5, 1, 0, 1, 0])
    return stage, skel, anim, binding


def test_a_good_stage_has_no_errors():
    assert skel_errors(_stage()[0]) == []


def test_joint_order_and_duplicates():
    stage, skel, _, _ = _stage()
    skel.GetJointsAttr().Set(["A/B", "A"])
    assert any("before its parent" in e for e in skel_errors(stage))
    skel.GetJointsAttr().Set(["A", "A"])
    assert any("twice" in e for e in skel_errors(stage))


def test_missing_channel():
    stage, _, anim, _ = _stage()
    anim.GetScalesAttr().Clear()
    assert any("scales is not authored" in e for e in skel_errors(stage))


def test_joint_index_range_and_weight_sums():
    stage, _, _, binding = _stage()
    binding.GetJointIndicesPrimvar().Set([0, 2, 1, 0, 0, 0])
    assert any("outside" in e for e in skel_errors(stage))
    stage, _, _, binding = _stage()
    binding.GetJointWeightsPrimvar().Set([0.5, 0.4, 1, 0, 1, 0])
    assert any("sum to 1" in e for e in skel_errors(stage))


def test_element_size_mismatch():
    stage, _, _, binding = _stage()
    binding.GetJointWeightsPrimvar().SetElementSize(3)
    assert any("elementSize" in e for e in skel_errors(stage))


def test_export_is_deterministic(empty_scene):
    arm = make_armature("Rig")
    tube = make_tube("Body")
    weight_by_height(tube, ("Bone0", "Bone1", "Bone2"))
    add_armature_modifier(tube, arm)
    animate_pose(arm)
    first, _ = export_current()  # keep the stages: a layer dies with its stage
    second, _ = export_current()
    assert first.GetRootLayer().ExportToString() == second.GetRootLayer().ExportToString()
