"""NURBS patches (docs/stage_contract.md "Gprims"): drawn as Storm draws them, their
control hull as a mesh: the uVertexCount x vVertexCount control points joined into
quads, wound by the patch's orientation, shaded with smooth normals. The knots and
weights are not evaluated, so the image is the hull's, not the surface's."""
import numpy as np

U, V = 4, 3


def _stage():
    from pxr import Gf, Usd, UsdGeom
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(0.5, 0.2, 10))
    cam.CreateProjectionAttr("orthographic")
    cam.CreateHorizontalApertureAttr(80.0)          # 8 units across
    cam.CreateVerticalApertureAttr(80.0)
    return stage


def _grid():
    """Control points, u fastest: 4 across x, 3 along y, bumped in z."""
    return [(x * 1.5 - 2.0, y * 1.5 - 1.5, 0.6 * ((x + y) % 2)) for y in range(V)
            for x in range(U)]


def _patch(stage, path, orientation=None):
    from pxr import Gf, UsdGeom
    patch = UsdGeom.NurbsPatch.Define(stage, path)
    patch.CreatePointsAttr([Gf.Vec3f(*p) for p in _grid()])
    patch.CreateUVertexCountAttr(U)
    patch.CreateVVertexCountAttr(V)
    patch.CreateUOrderAttr(4)
    patch.CreateVOrderAttr(3)
    patch.CreateUKnotsAttr([0, 0, 0, 0, 1, 1, 1, 1])
    patch.CreateVKnotsAttr([0, 0, 0, 1, 1, 1])
    if orientation:
        patch.CreateOrientationAttr(orientation)
    return patch.GetPrim()


def _hull_mesh(stage, path):
    """The same hull authored as a polygon Mesh (scheme none)."""
    from pxr import Gf, UsdGeom
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in _grid()])
    quads = [(v * U + u, v * U + u + 1, (v + 1) * U + u + 1, (v + 1) * U + u)
             for v in range(V - 1) for u in range(U - 1)]
    mesh.CreateFaceVertexCountsAttr([4] * len(quads))
    mesh.CreateFaceVertexIndicesAttr([i for q in quads for i in q])
    mesh.CreateSubdivisionSchemeAttr("none")


def _render(stage):
    from lantern.engine import RenderSettings, render_stage
    return render_stage(stage, RenderSettings(width=64, height=64, preset="low",
                                              transparent=True))


def test_a_nurbs_patch_draws_its_control_hull_as_storm_does():
    stage = _stage()
    _patch(stage, "/Patch")
    patch = _render(stage)
    stage.RemovePrim("/Patch")
    _hull_mesh(stage, "/Hull")
    hull = _render(stage)
    assert not patch.warnings, patch.warnings
    covered = patch.rgba[..., 3] > 0.5
    # The hull spans 4.5 x 3 units of the 8 x 8 in view: 64 * 64 * 13.5 / 64 pixels.
    assert abs(int(covered.sum()) - 864) < 40, covered.sum()
    assert np.array_equal(covered, hull.rgba[..., 3] > 0.5)
    assert np.abs(patch.rgba - hull.rgba).max() < 1e-5


def test_a_left_handed_patch_winds_its_quads_the_other_way_and_bad_counts_warn():
    from pxr import Usd
    from lantern.engine.usd.patches import hull_surface
    stage = _stage()
    right = hull_surface(_patch(stage, "/R"), Usd.TimeCode.Default())
    left = hull_surface(_patch(stage, "/L", "leftHanded"), Usd.TimeCode.Default())
    assert list(right.indices[:4]) == [0, 1, 5, 4]
    assert list(left.indices[:4]) == [4, 5, 1, 0]
    bad = _patch(stage, "/Bad")
    bad.GetAttribute("uVertexCount").Set(5)
    result = _render(stage)
    assert [w for w in result.warnings if w.startswith("/Bad")] == [
        "/Bad: malformed mesh (12 points for uVertexCount x vVertexCount = 15); skipped"]
