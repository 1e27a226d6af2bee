"""GPU skinning and blend shapes (UsdSkel) against OpenUSD's own results: the baked
baselines of testUsdSkelBakeSkinning, UsdSkel's CPU skinning, and UsdSkel.BakeSkinning
renders; malformed bindings, 1,000+ joints, >8 influences, frustum culling."""
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdSkel, Vt

from lantern.engine import RenderSettings, Session, render_stage, skinned_points
from lantern.engine.usd.skel import SkelBindings
from _export_helpers import skinned_stage  # UsdSkel.BakeSkinning on an in-memory copy
from skel_scenes import skel_stage

SKEL = "usdskel/usd/usdSkel/testenv/testUsdSkelBakeSkinning"


def world_points(stage, path, t):
    prim = stage.GetPrimAtPath(path)
    pts = np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get(t), np.float64)
    xf = np.array(UsdGeom.XformCache(t).GetLocalToWorldTransform(prim)).T
    return pts @ xf[:3, :3].T + xf[:3, 3]


@pytest.mark.parametrize("name", ["lbs", "dqs", "blendshapes", "blendshapesWithNormals"])
def test_gpu_skinning_matches_usd_baked_baseline(corpus, name):
    stage = Usd.Stage.Open(str(corpus / SKEL / f"{name}.usda"))
    base = Usd.Stage.Open(str(corpus / SKEL / "baseline" / f"{name}.baked.usda"))
    session = Session(stage, RenderSettings(width=1, height=1))
    times = set()
    moved = 0.0
    for prim in base.Traverse():
        if prim.IsA(UsdGeom.Mesh) and stage.GetPrimAtPath(prim.GetPath()):
            times |= set(UsdGeom.Mesh(prim).GetPointsAttr().GetTimeSamples())
            times |= set(UsdGeom.Mesh(prim).GetNormalsAttr().GetTimeSamples())
    assert times
    worst = {}
    for t in sorted(times):
        got = session.skinned_points(t)
        assert got, "no skinned mesh read"
        for path, (pts, nrm) in got.items():
            if not base.GetPrimAtPath(path).IsA(UsdGeom.Mesh):
                continue          # rigidly skinned implicit surfaces (test_curves.py)
            ref = world_points(base, path, t)
            diag = np.linalg.norm(ref.max(0) - ref.min(0))
            err = np.abs(pts - ref).max() / diag
            worst[path] = max(worst.get(path, 0.0), err)
            assert err <= 1e-5, (path, t, err)
            moved = max(moved, np.abs(ref - world_points(stage, path, t)).max() / diag)
            ref_n = UsdGeom.Mesh(base.GetPrimAtPath(path)).GetNormalsAttr().Get(t)
            if ref_n is not None and len(ref_n) == len(pts) and \
                    UsdGeom.Mesh(base.GetPrimAtPath(path)).GetNormalsInterpolation() == "vertex":
                rn = np.array(ref_n, np.float64)
                rn /= np.linalg.norm(rn, axis=1, keepdims=True)
                gn = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
                assert np.abs(gn - rn).max() < 1e-4, (path, t, "normals")
    session.close()
    print(name, {p: f"{e:.2e}" for p, e in worst.items()})
    if name != "blendshapesWithNormals":      # that file only moves normals
        assert moved > 1e-3                    # the baselines do deform the rest pose


@pytest.mark.parametrize("rel", [
    "usdskel/usdImaging/usdImagingGL/testenv/testUsdImagingGLSkelSkinning/test_lbs.usda",
    "usdskel/usdImaging/usdImagingGL/testenv/testUsdImagingGLUsdSkel/arm.usda",
    "usdskel/usd/usdSkel/doxygen/skinnedArm.usda"])
def test_gpu_skinning_matches_usdskel_cpu(corpus, rel):
    stage = Usd.Stage.Open(str(corpus / rel))
    bindings = SkelBindings(stage)
    t0, t1 = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    with Session(stage, RenderSettings(width=1, height=1)) as session:
        frames = [(t, session.skinned_points(float(t))) for t in np.linspace(t0, t1, 4)]
    for t, got in frames:
        assert got
        for path, (pts, _) in got.items():
            skel_query, sq = bindings.get(path)
            prim = stage.GetPrimAtPath(path)
            ref = Vt.Vec3fArray(UsdGeom.Mesh(prim).GetPointsAttr().Get(t))
            xforms = skel_query.ComputeSkinningTransforms(t)
            assert sq.ComputeSkinnedPoints(xforms, ref, t)
            skel_world = np.array(UsdGeom.XformCache(t).GetLocalToWorldTransform(
                skel_query.GetPrim())).T
            ref = np.array(ref, np.float64) @ skel_world[:3, :3].T + skel_world[:3, 3]
            diag = np.linalg.norm(ref.max(0) - ref.min(0))
            assert np.abs(pts - ref).max() / diag <= 1e-5, (path, t)


# --- procedural skeletons ------------------------------------------------------------

def cpu_skinned(stage, bindings, path, t):
    skel_query, sq = bindings.get(path)
    pts = Vt.Vec3fArray(UsdGeom.Mesh(stage.GetPrimAtPath(path)).GetPointsAttr().Get())
    assert sq.ComputeSkinnedPoints(skel_query.ComputeSkinningTransforms(t), pts, t)
    return np.array(pts, np.float64)


@pytest.mark.parametrize("method", ["classicLinear", "dualQuaternion"])
def test_non_uniform_scale_matches_usdskel(method):
    """DQS splits off the joints' scale the way UsdSkel.SkinPoints does."""
    stage = skel_stage(4, method=method, scale=(1.5, 0.7, 1.2), influences=3)
    bindings = SkelBindings(stage)
    for t in (1, 2, 3):
        got = skinned_points(stage, t)["/root/mesh"][0]
        ref = cpu_skinned(stage, bindings, "/root/mesh", t)
        diag = np.linalg.norm(ref.max(0) - ref.min(0))
        assert np.abs(got - ref).max() / diag <= 1e-5, (method, t)


def test_thousand_joints():
    stage = skel_stage(1200, influences=8, grid=200)
    bindings = SkelBindings(stage)
    assert len(bindings.get("/root/mesh")[0].GetJointOrder()) == 1200
    got = skinned_points(stage, 3)["/root/mesh"][0]
    ref = cpu_skinned(stage, bindings, "/root/mesh", 3)
    diag = np.linalg.norm(ref.max(0) - ref.min(0))
    assert np.abs(got - ref).max() / diag <= 1e-5
    res = render_stage(stage, RenderSettings(width=48, height=32, frame=3))
    assert res.stats["draw_calls"] == 1 and np.isfinite(res.rgba).all()


@pytest.mark.parametrize("influences", [10, 16])
def test_more_than_eight_influences_all_kept_and_exact(influences):
    """Past 8 influences the weights come from a per-point texture: none dropped."""
    stage = skel_stage(24, influences=influences)
    bindings = SkelBindings(stage)
    with Session(stage, RenderSettings(width=1, height=1)) as session:
        got = {t: session.skinned_points(t)["/root/mesh"][0] for t in (1, 2, 3)}
        skin = session.scene.meshes[("skinned", "/root/mesh")].skin
    assert skin.point_influences is not None
    assert skin.joints.shape[1] >= influences
    for t in (1, 2, 3):
        ref = cpu_skinned(stage, bindings, "/root/mesh", t)
        diag = np.linalg.norm(ref.max(0) - ref.min(0))
        assert np.abs(got[t] - ref).max() / diag <= 1e-5, t
    res = render_stage(stage, RenderSettings(width=32, height=24, frame=2))
    assert not res.warnings and np.isfinite(res.rgba).all()


@pytest.mark.parametrize("defect", ["index", "size"])
def test_malformed_binding_warns_and_draws_unskinned(defect):
    stage = skel_stage(3)
    binding = UsdSkel.BindingAPI(stage.GetPrimAtPath("/root/mesh"))
    pv = binding.GetJointIndicesPrimvar()
    vals = list(pv.Get())
    if defect == "index":
        vals[5] = 99
        pv.Set(Vt.IntArray(vals))
    else:
        pv.Set(Vt.IntArray(vals[:-4]))
        binding.GetJointWeightsPrimvar().Set(Vt.FloatArray(list(binding.GetJointWeightsPrimvar().Get())[:-4]))
    res = render_stage(stage, RenderSettings(width=48, height=32, frame=3, transparent=True))
    msg = [w for w in res.warnings if w.startswith("/root/mesh:")]
    assert msg and "drawn unskinned" in msg[0], res.warnings
    assert ("range" in msg[0]) if defect == "index" else ("influences" in msg[0])
    assert res.stats["draw_calls"] == 1 and res.rgba[..., 3].sum() > 0
    assert skinned_points(stage, 3) == {}       # no skin: the rest pose is drawn


@pytest.mark.parametrize("method", ["classicLinear", "dualQuaternion"])
def test_render_skinned_equals_render_baked(method):
    stage = skel_stage(5, method=method, influences=3, grid=12, rot_deg=60)
    # Authored normals (UsdSkel bakes them too) and a fixed camera: the default one
    # frames the stage's bounds, which do not know about skinning.
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/root/mesh"))
    pts = np.array(mesh.GetPointsAttr().Get())
    nrm = np.stack([-0.2 * np.cos(pts[:, 0]), np.zeros(len(pts)), np.ones(len(pts))], 1)
    mesh.CreateNormalsAttr([Gf.Vec3f(*n) for n in nrm / np.linalg.norm(nrm, axis=1, keepdims=True)])
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    look(stage, (2, -8, 5), (2, 0, 0))
    baked = skinned_stage(stage)
    assert not UsdSkel.BindingAPI(baked.GetPrimAtPath("/root/mesh")).GetJointIndicesPrimvar().HasValue() \
        or SkelBindings(baked).get("/root/mesh") is None
    for t in (1, 3):
        # Geometry against geometry: no screen-space effect spreads float rounding.
        s = RenderSettings(width=96, height=64, frame=t, ambient_occlusion=False, fxaa=False)
        a = render_stage(stage, s).rgba
        b = render_stage(baked, s).rgba
        diff = np.abs(a - b).max()
        print(method, t, "max abs diff", diff)
        assert diff <= 1e-3


def look(stage, eye, target):
    cam = UsdGeom.Camera.Define(stage, "/cam")
    UsdGeom.Xformable(cam).AddTransformOp().Set(
        Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(0, 0, 1)).GetInverse())
    return cam


def test_culled_mesh_costs_no_draw_call():
    stage = skel_stage(3)
    look(stage, (2, -12, 3), (2, 0, 0))
    far = UsdGeom.Mesh.Define(stage, "/far")
    far.CreateSubdivisionSchemeAttr("none")
    far.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    far.CreateFaceVertexCountsAttr([3])
    far.CreateFaceVertexIndicesAttr([0, 1, 2])
    UsdGeom.Xformable(far).AddTranslateOp().Set((500, 0, 0))
    res = render_stage(stage, RenderSettings(width=48, height=32, frame=2))
    assert res.stats["culled"] == 1 and res.stats["draw_calls"] == 1
    # Animate the skeleton root off screen: the skinned mesh is culled by its pose.
    UsdGeom.Xformable(stage.GetPrimAtPath("/root/skel")).AddTranslateOp().Set(Gf.Vec3d(0, 0, 0), 1)
    UsdGeom.Xformable(stage.GetPrimAtPath("/root/skel")).GetOrderedXformOps()[0].Set(
        Gf.Vec3d(0, 0, 300), 3)
    assert render_stage(stage, RenderSettings(width=48, height=32, frame=1)).stats["draw_calls"] == 1
    res = render_stage(stage, RenderSettings(width=48, height=32, frame=3))
    assert res.stats["culled"] == 2 and res.stats["draw_calls"] == 0


def test_static_meshes_get_no_skinning_code():
    from lantern.engine import skin
    from lantern.engine.gpu.programs import SHADER_DIR
    assert skin.defines(None) == []
    src = open(f"{SHADER_DIR}/skinning.glsl").read()
    assert "#ifdef SKIN_JOINTS" in src


def test_skinned_meshes_cast_posed_shadows():
    """With a shadow-casting sun over a floor, the skinned stage and its UsdSkel-baked
    copy give the same image: the shadow pass skins casters as the G-buffer does, and
    fits the sun's cascades to the posed geometry. The fit uses bounds (joint-padded
    when skinned, exact when baked), so the shadow texels fall a little differently:
    a few edge pixels differ slightly. Rest-pose casters differed in ~1,000 pixels."""
    stage = skel_stage(5, influences=3, grid=12, rot_deg=60)
    # Authored normals, which UsdSkel bakes too (see test_render_skinned_equals_render_baked).
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/root/mesh"))
    mesh.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * len(mesh.GetPointsAttr().Get()))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    floor = UsdGeom.Mesh.Define(stage, "/root/floor")
    floor.CreateSubdivisionSchemeAttr("none")
    floor.CreatePointsAttr([(-6, -6, -1.5), (10, -6, -1.5), (10, 6, -1.5), (-6, 6, -1.5)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    sun = UsdLux.DistantLight.Define(stage, "/root/sun")
    sun.CreateIntensityAttr(3.0)
    sun.CreateNormalizeAttr(True)
    UsdLux.ShadowAPI.Apply(sun.GetPrim()).CreateShadowEnableAttr(True)
    sun.AddTransformOp().Set(Gf.Matrix4d().SetLookAt(
        Gf.Vec3d(0, 0, 0), Gf.Vec3d(0.3, 0.2, -1), Gf.Vec3d(0, 1, 0)).GetInverse())
    look(stage, (2, -8, 5), (2, 0, -1))
    baked = skinned_stage(stage)
    for t in (1, 3):
        # Geometry against geometry: no screen-space effect spreads float rounding.
        s = RenderSettings(width=96, height=64, frame=t, ambient_occlusion=False, fxaa=False)
        a = render_stage(stage, s)
        b = render_stage(baked, s)
        assert a.stats["shadow_maps"] == 1
        difference = np.abs(a.rgba - b.rgba)[..., :3].max(axis=-1)
        assert (difference > 0.01).mean() < 0.01 and difference.max() < 0.06, t
    rest = render_stage(stage, RenderSettings(width=96, height=64, frame=1)).rgba
    posed = render_stage(stage, RenderSettings(width=96, height=64, frame=3)).rgba
    assert np.abs(rest - posed).max() > 0.05, "the pose did not change the image"
