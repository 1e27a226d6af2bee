"""Never a silent blank (docs/stage_contract.md "What the engine refuses or skips"):
every prim type the engine does not draw is one warning per type with its count,
and a stage whose gprims put nothing on screen says so in one line, naming what was
there and where the camera looked. Each stage renders through its default view
(no camera), as `lantern render` does for a file without one."""
import pytest


def _stage():
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    return stage


def _render(stage, **settings):
    from lantern.engine import RenderSettings, render_stage
    return render_stage(stage, RenderSettings(**{"width": 48, "height": 32, "preset": "low",
                                                 **settings}))


def _volume(stage, path):
    from pxr import UsdVol
    vol = UsdVol.Volume.Define(stage, path)
    field = UsdVol.OpenVDBAsset.Define(stage, path + "/density")
    field.CreateFilePathAttr("density.vdb")
    vol.CreateFieldRelationship("density", field.GetPath())


def _tet_mesh(stage, path):
    from pxr import Gf, UsdGeom
    tet = UsdGeom.TetMesh.Define(stage, path)
    tet.CreatePointsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0),
                          Gf.Vec3f(0, 0, 1)])
    tet.CreateTetVertexIndicesAttr([Gf.Vec4i(0, 1, 2, 3)])


def _hermite(stage, path):
    from pxr import Gf, UsdGeom
    curves = UsdGeom.HermiteCurves.Define(stage, path)
    curves.CreatePointsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0)])
    curves.CreateTangentsAttr([Gf.Vec3f(1, 1, 0), Gf.Vec3f(1, -1, 0)])
    curves.CreateCurveVertexCountsAttr([2])


def _unknown(stage, path):
    stage.DefinePrim(path, "Teapot")


KINDS = {
    "Volume": (_volume, "Lantern draws no volumes"),
    "TetMesh": (_tet_mesh, "Lantern draws no tetrahedral meshes"),
    "HermiteCurves": (_hermite, "Lantern does not draw Hermite curves"),
    "Teapot (unknown type)": (_unknown, "no schema defines the type"),
}


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_a_stage_of_an_unsupported_type_warns_once_with_its_count(kind):
    make, reason = KINDS[kind]
    stage = _stage()
    for i in range(4):
        make(stage, f"/Thing{i}")
    result = _render(stage)
    lines = [w for w in result.warnings if "not drawn" in w]
    assert lines == [f"4 {kind} prims are not drawn ({reason}): /Thing0, /Thing1, /Thing2 "
                     f"and 1 more"]
    name = kind.split(" ")[0]
    blank = [w for w in result.warnings if w.startswith("nothing is on screen")]
    assert blank == [f"nothing is on screen: the stage has 4 gprims ({kind} 4); nothing of "
                     f"them is drawn; the camera <default camera> at " + blank[0].split(
                         "<default camera> at ")[1]], result.warnings
    assert name in blank[0]


def test_undrawn_types_beside_drawn_ones_warn_and_the_image_is_not_blank():
    from pxr import UsdGeom
    stage = _stage()
    UsdGeom.Sphere.Define(stage, "/Ball")
    _volume(stage, "/Smoke")
    _tet_mesh(stage, "/Tet")
    result = _render(stage)
    assert sorted(w for w in result.warnings if "not drawn" in w) == [
        "1 TetMesh prim is not drawn (Lantern draws no tetrahedral meshes): /Tet",
        "1 Volume prim is not drawn (Lantern draws no volumes): /Smoke"]
    assert not [w for w in result.warnings if w.startswith("nothing is on screen")]
    assert result.stats["fragments_drawn"] > 0


def test_a_camera_looking_away_says_what_was_there_and_where_it_looked():
    from pxr import Gf, UsdGeom
    stage = _stage()
    UsdGeom.Sphere.Define(stage, "/Ball").AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    UsdGeom.Cube.Define(stage, "/Box").AddTranslateOp().Set(Gf.Vec3d(0, 0, 12))
    cam = UsdGeom.Camera.Define(stage, "/Cam")          # at the origin, looking along -Z
    result = _render(stage, camera="/Cam")
    assert result.stats["fragments_drawn"] == 0
    assert [w for w in result.warnings if w.startswith("nothing is on screen")] == [
        "nothing is on screen: the stage has 2 gprims (Cube 1, Sphere 1); what is drawn lies "
        "within (-1, -1, 9)..(1, 1, 13); the camera /Cam at (0, 0, 0) looks along (0, 0, -1)"]
    cam.AddRotateXOp().Set(180.0)                        # now looking at them
    result = _render(stage, camera="/Cam")
    assert result.stats["fragments_drawn"] > 0
    assert not [w for w in result.warnings if w.startswith("nothing is on screen")]


def test_lantern_render_prints_the_warnings(tmp_path):
    import subprocess
    import sys
    stage_path = tmp_path / "volume.usda"
    stage = _stage()
    _volume(stage, "/Smoke")
    stage.GetRootLayer().Export(str(stage_path))
    out = subprocess.run([sys.executable, "-m", "lantern", "render", str(stage_path), "-o",
                          str(tmp_path / "out.exr"), "--size", "32x32", "--preset", "low"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "warning: 1 Volume prim is not drawn (Lantern draws no volumes): /Smoke" in out.stderr
    assert "warning: nothing is on screen: the stage has 1 gprim (Volume 1)" in out.stderr
