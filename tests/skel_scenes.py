"""Skinned scenes made with the USD API (no bpy), for the skinning tests and the GPU
machine's checks: a procedural skeleton and grid, and the crowd (two meshes on one
skeleton, a blend shape, two shadowed lights)."""
import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

import shadow_scenes


def skel_stage(n_joints=3, method=None, scale=None, influences=2, grid=6, rot_deg=40.0):
    """A Z-up SkelRoot: a flat chain of joints along X, an animated rotation about Y
    per joint (frames 1..3), and a grid mesh bound to them."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(3)
    root = UsdSkel.Root.Define(stage, "/root")
    skel = UsdSkel.Skeleton.Define(stage, "/root/skel")
    names = [f"j{i}" for i in range(n_joints)]
    length = 4.0
    bind = [Gf.Matrix4d().SetTranslate(Gf.Vec3d(length * i / n_joints, 0, 0)) for i in range(n_joints)]
    skel.CreateJointsAttr(names)
    skel.CreateBindTransformsAttr(bind)
    skel.CreateRestTransformsAttr(bind)
    anim = UsdSkel.Animation.Define(stage, "/root/skel/anim")
    anim.CreateJointsAttr(names)
    anim.CreateTranslationsAttr([Gf.Vec3f(length * i / n_joints, 0, 0) for i in range(n_joints)])
    sc = scale if scale is not None else (1, 1, 1)
    anim.CreateScalesAttr([Gf.Vec3h(*sc)] * n_joints)
    rot = anim.CreateRotationsAttr()
    for t in (1, 2, 3):
        a = np.radians(rot_deg * (t - 1) / 2)
        q = Gf.Quatf(float(np.cos(a / 2)), Gf.Vec3f(0, float(np.sin(a / 2)), 0))
        rot.Set([q] * n_joints, t)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    UsdSkel.BindingAPI.Apply(root.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])

    mesh = UsdGeom.Mesh.Define(stage, "/root/mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    xs, ys = np.linspace(0, length, grid), np.linspace(-0.5, 0.5, 3)
    pts = np.array([(x, y, 0.2 * np.sin(x)) for y in ys for x in xs])
    faces = [(r * grid + c, r * grid + c + 1, (r + 1) * grid + c + 1, (r + 1) * grid + c)
             for r in range(2) for c in range(grid - 1)]
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in pts])
    mesh.CreateFaceVertexCountsAttr([4] * len(faces))
    mesh.CreateFaceVertexIndicesAttr([i for f in faces for i in f])
    mesh.CreateDoubleSidedAttr(True)
    rng = np.random.default_rng(7)
    n = len(pts)
    idx = rng.integers(0, n_joints, size=(n, influences))
    w = rng.random((n, influences)) + 0.1
    w /= w.sum(axis=1, keepdims=True)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateJointIndicesPrimvar(False, influences).Set(Vt.IntArray(idx.reshape(-1).tolist()))
    binding.CreateJointWeightsPrimvar(False, influences).Set(Vt.FloatArray(w.reshape(-1).tolist()))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, 0, 0.1)))
    if method:
        binding.CreateSkinningMethodAttr(method)
    return stage



def crowd_stage():
    """Two meshes skinned by one skeleton (the second also has an animated blend shape)
    over a floor, a shadowed point and a shadowed spot light, a camera."""
    stage = skel_stage(4, influences=2, grid=10, rot_deg=80)
    src = stage.GetPrimAtPath("/root/mesh")
    second = UsdGeom.Mesh.Define(stage, "/root/mesh2")
    second.CreateSubdivisionSchemeAttr("none")
    for name in ("points", "faceVertexCounts", "faceVertexIndices", "doubleSided"):
        second.GetPrim().CreateAttribute(name, src.GetAttribute(name).GetTypeName()).Set(
            src.GetAttribute(name).Get())
    n = len(second.GetPointsAttr().Get())
    b = UsdSkel.BindingAPI.Apply(second.GetPrim())
    b.CreateJointIndicesPrimvar(True, 1).Set(Vt.IntArray([1]))
    b.CreateJointWeightsPrimvar(True, 1).Set(Vt.FloatArray([1.0]))
    b.CreateGeomBindTransformAttr(Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, 1.5, 0)))
    shape = UsdSkel.BlendShape.Define(stage, "/root/mesh2/bulge")
    shape.CreateOffsetsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0.4)] * n))
    b.CreateBlendShapesAttr(["bulge"])
    b.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
    anim = UsdSkel.Animation(stage.GetPrimAtPath("/root/skel/anim"))
    anim.CreateBlendShapesAttr(["bulge"])
    for t, w in ((1, 0.0), (2, 0.7), (3, 1.0)):
        anim.CreateBlendShapeWeightsAttr().Set(Vt.FloatArray([w]), t)
    floor = UsdGeom.Mesh.Define(stage, "/floor")
    floor.CreateSubdivisionSchemeAttr("none")
    floor.CreatePointsAttr([(-6, -6, -1.5), (10, -6, -1.5), (10, 6, -1.5), (-6, 6, -1.5)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    for kind, kw in (("point", dict(pos=(1.0, -2.0, 4.0), power=3000.0)),
                     ("spot", dict(pos=(4.0, 3.0, 5.0), aim=(2, 0, 0), power=6000.0, cone=45.0))):
        shadow_scenes.add_light(stage, kind, **kw)
    shadow_scenes.add_camera(stage, eye=(2, -9, 5), target=(2, 0, 0))
    return stage
