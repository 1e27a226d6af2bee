"""Skinning in the engine: blend shapes whose mesh lists only some of its animation's
shapes (a key relative to itself is not written on the mesh; a rig with two keyed
meshes animates all their keys) go through UsdSkel's blend-shape mapper, which takes
float weights: glTF-Blender-IO's 25_drivers_disable_viewport and 28_various_sk failed
there ("Unexpected type [double] for defaultValue"). Rebuilt here from a small bpy
scene with the same shape-key set-up; the GPU's points match UsdSkel's own
BakeSkinning within 1e-5 of the bounding-box diagonal at every frame."""
import numpy as np
import pytest


def _keyed_tube():
    import bpy
    from _export_helpers import make_tube
    tube = make_tube("Keyed")
    tube.shape_key_add(name="Basis")
    rng = np.random.default_rng(5)
    keys = []
    for name in ("Key_1", "Key_2", "Key_3"):
        kb = tube.shape_key_add(name=name, from_mix=False)
        co = np.empty(len(kb.data) * 3, dtype=np.float32)
        kb.data.foreach_get("co", co)
        kb.data.foreach_set("co", co + rng.normal(0, 0.05, co.shape).astype(np.float32))
        keys.append(kb)
    keys[0].relative_key = keys[0]      # relative to itself: no offsets, not on the mesh
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 4
    for f in range(1, 5):
        for i, kb in enumerate(keys):
            kb.value = (0.3 * f + 0.2 * i) % 1.0
            kb.keyframe_insert("value", frame=f)
    return tube


def test_blend_shapes_through_a_non_identity_mapper(empty_scene, hard_case):
    from _export_helpers import export_current, skinned_stage
    from pxr import UsdGeom, UsdSkel
    from lantern.engine import RenderSettings, render_stage, skinned_points
    _keyed_tube()
    stage, _ = export_current()
    anim = next(p for p in stage.Traverse() if p.IsA(UsdSkel.Animation))
    mesh = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    anim_shapes = list(UsdSkel.Animation(anim).GetBlendShapesAttr().Get())
    mesh_shapes = list(UsdSkel.BindingAPI(mesh).GetBlendShapesAttr().Get())
    assert mesh_shapes != anim_shapes                 # the mapper is not the identity
    baked = skinned_stage(stage)
    worst = 0.0
    for frame in (1.0, 2.5, 4.0):
        got = skinned_points(stage, frame)[str(mesh.GetPath())][0]
        m = UsdGeom.Mesh(baked.GetPrimAtPath(mesh.GetPath()))
        pts = np.array(m.GetPointsAttr().Get(frame), np.float64)
        xf = np.array(m.ComputeLocalToWorldTransform(frame))
        want = pts @ xf[:3, :3] + xf[3, :3]
        diag = float(np.linalg.norm(want.max(0) - want.min(0)))
        worst = max(worst, float(np.abs(got - want).max()) / diag)
    rgba = render_stage(stage, RenderSettings(width=64, height=36, frame=2.0)).rgba
    assert np.isfinite(rgba).all() and rgba[..., :3].max() > 0
    hard_case("blend shapes through a non-identity mapper (key relative to itself): GPU vs "
              "UsdSkel / diag", worst, 1e-5)


SKEL_BAKE = ("usdskel", "usd", "usdSkel", "testenv", "testUsdSkelBakeSkinning")
TWIN_MESHES = ("Mesh", "MeshWithNormals", "MeshWithFaceVaryingNormals")
SPLIT = "Mesh+faceVarying st"   # Mesh with per-corner UVs: a point is several vertices


def _one_mesh(path, keep, bake):
    """The corpus rig with only `keep` active (and /GroundTruth off); baked: UsdSkel's
    own BakeSkinning of it, flattened (points and normals time-sampled, no rig)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel
    stage = Usd.Stage.CreateInMemory()
    stage.GetRootLayer().TransferContent(Usd.Stage.Open(str(path)).Flatten())
    if keep == SPLIT:
        keep = "Mesh"
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/Root/Mesh"))
        corners = len(mesh.GetFaceVertexIndicesAttr().Get())
        st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                     UsdGeom.Tokens.faceVarying)
        st.Set([(0.1 * (i % 7), 0.1 * (i % 5)) for i in range(corners)])
    for prim in list(stage.Traverse()):
        if prim.GetName() == "GroundTruth" or \
                prim.GetParent().GetPath() == "/Root" and prim.GetName() in TWIN_MESHES and \
                prim.GetName() != keep:
            prim.SetActive(False)
    if bake:
        assert UsdSkel.BakeSkinning(stage.Traverse(), Gf.Interval(stage.GetStartTimeCode(),
                                                                  stage.GetEndTimeCode()))
        flat = Usd.Stage.CreateInMemory()
        flat.GetRootLayer().TransferContent(stage.Flatten())
        stage = flat
    return stage


def _worst_difference(deformed, baked):
    """Largest pixel difference of two stages' renders at frames 5, 16 and 25 (48x48,
    AO and FXAA off), each image checked to show a shaded mesh."""
    from lantern.engine import RenderSettings, render_stage
    worst = 0.0
    for frame in (5.0, 16.0, 25.0):
        settings = RenderSettings(width=48, height=48, frame=frame, preset="low",
                                  ambient_occlusion=False, fxaa=False)
        a = render_stage(deformed, settings).rgba[..., :3]
        b = render_stage(baked, settings).rgba[..., :3]
        assert (np.abs(a - a.mean()) > 1e-3).sum() > 200      # the mesh is in view, shaded
        worst = max(worst, float(np.abs(a - b).max()))
    return worst


@pytest.mark.parametrize("method", ["lbs", "dqs"])
@pytest.mark.parametrize("mesh", TWIN_MESHES + (SPLIT,))
def test_skinned_mesh_renders_as_its_baked_twin(corpus, hard_case, method, mesh):
    """A GPU-skinned mesh and UsdSkel's baking of it are one surface: authored normals
    are skinned and normalised as UsdSkel does, and a mesh without them gets its
    deformed surface's own each frame (as the baked twin, whose normals are computed
    from its baked points). Before, unnormalised skinned normals and rest normals
    skinned instead of recomputed differed by up to 0.12."""
    path = corpus.joinpath(*SKEL_BAKE, f"{method}.usda")
    worst = _worst_difference(_one_mesh(path, mesh, False), _one_mesh(path, mesh, True))
    hard_case(f"{method} {mesh}: skinned vs UsdSkel-baked twin, frames 5, 16, 25 (max pixel "
              f"difference)", worst, 1e-4)


def _blend_shaped_grid():
    """A grid without normals whose one blend shape raises a bump (weight 0 at frame
    1, 1 at frame 30): blend shapes only, no joint influences."""
    from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt
    stage = Usd.Stage.CreateInMemory()
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(30)
    root = UsdSkel.Root.Define(stage, "/Root")
    skel = UsdSkel.Skeleton.Define(stage, "/Root/Skel")
    skel.CreateJointsAttr(["j"])
    skel.CreateBindTransformsAttr([Gf.Matrix4d(1)])
    skel.CreateRestTransformsAttr([Gf.Matrix4d(1)])
    anim = UsdSkel.Animation.Define(stage, "/Root/Skel/Anim")
    anim.CreateBlendShapesAttr(["bump"])
    weights = anim.CreateBlendShapeWeightsAttr()
    weights.Set([0.0], 1)
    weights.Set([1.0], 30)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    UsdSkel.BindingAPI.Apply(root.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])
    n = 12
    xs, ys = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n))
    points = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], 1)
    r, c = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (r * n + c).ravel()
    quads = np.stack([a, a + 1, a + n + 1, a + n], 1)
    mesh = UsdGeom.Mesh.Define(stage, "/Root/Grid")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr([4] * len(quads))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.ravel().astype(np.int32)))
    shape = UsdSkel.BlendShape.Define(stage, "/Root/Grid/bump")
    offsets = np.zeros_like(points)
    offsets[:, 2] = 0.6 * np.exp(-3 * (points[:, 0] ** 2 + points[:, 1] ** 2))
    shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(offsets.astype(np.float32)))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateBlendShapesAttr(["bump"])
    binding.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
    return stage


def test_blend_shaped_mesh_renders_as_its_baked_twin(hard_case):
    """Blend shapes alone deform a mesh without normals: its normals are the deformed
    surface's too (0.062 apart before, rest normals drawn on the bump)."""
    from pxr import Gf, Usd, UsdSkel
    from lantern.engine import skinned_points
    shaped = _blend_shaped_grid()
    assert list(skinned_points(shaped, 16.0)) == ["/Root/Grid"]     # the GPU deforms it
    baked = Usd.Stage.CreateInMemory()
    baked.GetRootLayer().TransferContent(shaped.GetRootLayer())
    assert UsdSkel.BakeSkinning(baked.Traverse(), Gf.Interval(1, 30))
    worst = _worst_difference(shaped, baked)
    hard_case("blend-shaped grid without normals: vs UsdSkel-baked twin, frames 5, 16, 25 "
              "(max pixel difference)", worst, 1e-4)
