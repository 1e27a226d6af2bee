"""Whole-stage behaviour: default camera and lights, shared prototypes, malformed
meshes, textures, settings, the GL thread."""
import threading

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom

from lantern.engine import RenderSettings, render_stage
from lantern.engine.gpu.context import run_gl

W, H = 64, 48


def cube(stage, path, size=1.0, scheme="none"):
    """A cube Mesh; `scheme` is the subdivisionScheme authored (None: none authored, so
    the schema's fallback, catmullClark)."""
    s = size / 2
    mesh = UsdGeom.Mesh.Define(stage, path)
    if scheme is not None:
        mesh.CreateSubdivisionSchemeAttr(scheme)
    mesh.CreatePointsAttr([(x, y, z) for z in (-s, s) for y in (-s, s) for x in (-s, s)])
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr([0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4,
                                      2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5])
    return mesh


def new_stage():
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    return stage


def test_default_camera_and_lights_frame_a_cube():
    stage = new_stage()
    cube(stage, "/root/cube/mesh")
    # One sample a pixel: the framing is the geometry's, not the pixel filter's reach.
    res = render_stage(stage, RenderSettings(width=W, height=H, transparent=True,
                                             supersample=1))
    cov = res.rgba[..., 3]
    assert cov[H // 2, W // 2] == 1.0                    # the cube is in the middle
    assert cov[0].max() == 0 and cov[-1].max() == 0      # and wholly in frame
    assert cov[:, 0].max() == 0 and cov[:, -1].max() == 0
    assert cov.sum() > 0.1 * W * H                       # and not a speck
    lit = res.rgba[..., :3][cov == 1.0]     # whole pixels (edges: premultiplied by coverage)
    assert lit.min() > 0.02 and lit.mean() > 0.05        # headlight + grey dome
    # Opaque background shows the default dome.
    opaque = render_stage(stage, RenderSettings(width=W, height=H)).rgba
    assert opaque[0, 0, 3] == 1.0 and opaque[0, 0, 0] > 0


def test_default_camera_y_up():
    stage = new_stage()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    c = cube(stage, "/root/cube/mesh", 2.0)
    UsdGeom.Xformable(c).AddTranslateOp().Set((5, 5, 5))
    res = render_stage(stage, RenderSettings(width=W, height=H, transparent=True))
    assert res.rgba[H // 2, W // 2, 3] == 1.0
    assert res.rgba[0, :, 3].max() == 0


def test_shared_prototype_uploaded_once_drawn_twice():
    stage = new_stage()
    proto = stage.CreateClassPrim("/root/_prototypes")
    cube(stage, "/root/_prototypes/box")
    for name, x, inst in (("a", -1.5, False), ("b", 1.5, True)):
        xf = UsdGeom.Xform.Define(stage, f"/root/{name}")
        xf.AddTranslateOp().Set((x, 0, 0))
        child = stage.DefinePrim(f"/root/{name}/mesh")
        child.GetReferences().AddInternalReference("/root/_prototypes/box")
        child.SetInstanceable(inst)
    assert proto.IsAbstract()
    res = render_stage(stage, RenderSettings(width=W, height=H, transparent=True))
    assert res.stats["meshes_uploaded"] == 1
    assert res.stats["draw_calls"] == 2
    cov = res.rgba[..., 3]
    # Both copies visible: coverage on both sides with a gap between.
    cols = cov.max(axis=0) > 0
    runs = np.count_nonzero(np.diff(cols.astype(int)) == 1) + int(cols[0])
    assert runs == 2


def test_malformed_mesh_warns_and_rest_renders():
    stage = new_stage()
    cube(stage, "/root/good/mesh")
    bad = UsdGeom.Mesh.Define(stage, "/root/bad/mesh")
    bad.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    bad.CreateFaceVertexCountsAttr([3])
    bad.CreateFaceVertexIndicesAttr([0, 1, 99])
    res = render_stage(stage, RenderSettings(width=W, height=H, transparent=True))
    assert any("/root/bad/mesh" in w and "range" in w for w in res.warnings), res.warnings
    assert res.rgba[..., 3].sum() > 0


def test_counts_mismatch_warns():
    stage = new_stage()
    bad = UsdGeom.Mesh.Define(stage, "/root/bad")
    bad.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    bad.CreateFaceVertexCountsAttr([4])
    bad.CreateFaceVertexIndicesAttr([0, 1, 2])
    res = render_stage(stage, RenderSettings(width=16, height=16))
    assert any(w.startswith("/root/bad:") for w in res.warnings)
    assert np.isfinite(res.rgba).all()


def test_render_settings_from_stage_and_preset_validation():
    stage = new_stage()
    cube(stage, "/root/c/mesh")
    from pxr import UsdRender
    rs = UsdRender.Settings.Define(stage, "/Render/Settings")
    rs.CreateResolutionAttr(Gf.Vec2i(40, 20))
    res = render_stage(stage, RenderSettings())
    assert res.rgba.shape == (20, 40, 4) and res.rgba.dtype == np.float32
    assert set(res.timings) >= {"load", "gbuffer", "lights", "resolve", "total"}
    with pytest.raises(ValueError, match="low, medium, high, ultra"):
        render_stage(stage, RenderSettings(preset="insane"))


def test_gl_runs_on_its_own_thread_and_errors_propagate():
    name = run_gl(lambda ctx: threading.current_thread().name)
    assert name == "lantern-gl" and name != threading.current_thread().name

    def boom(ctx):
        raise RuntimeError("boom")
    with pytest.raises(RuntimeError, match="boom"):
        run_gl(boom)
    assert run_gl(lambda gl: gl.version) >= 330



@pytest.mark.parametrize("tessellation_px", [4.0, 0.0])    # GPU patches, CPU refinement
def test_a_mesh_without_a_scheme_is_a_subdivision_surface(tessellation_px):
    """subdivisionScheme's fallback is catmullClark: a cube that authors no scheme is
    drawn as one that authors catmullClark (both without Lantern's render level, so at
    the default level), smooth: it shrinks towards a sphere and covers fewer pixels
    than its cage. One that authors none stays its polygon cage. No warnings."""
    images = {}
    for scheme in (None, "catmullClark", "none"):
        stage = new_stage()
        cube(stage, "/root/c/mesh", size=1.5, scheme=scheme)
        res = render_stage(stage, RenderSettings(width=W, height=H, transparent=True,
                                                 tessellation_px=tessellation_px))
        assert not [w for w in res.warnings if "subdivision" in w], res.warnings
        images[scheme] = res.rgba
    assert np.array_equal(images[None], images["catmullClark"])
    coverage = {k: v[..., 3].sum() for k, v in images.items()}
    assert 0 < coverage[None] < 0.9 * coverage["none"]


def test_subdivision_cage_is_refined_to_its_render_level():
    """A refined cube shrinks towards a sphere: it covers fewer pixels than its cage."""
    coverage = []
    for level in (0, 3):
        stage = new_stage()
        mesh = cube(stage, "/root/c/mesh", size=1.5)
        mesh.CreateSubdivisionSchemeAttr("catmullClark")
        mesh.GetPrim().CreateAttribute("lantern:subdivisionRenderLevel",
                                       Sdf.ValueTypeNames.Int, custom=True).Set(level)
        res = render_stage(stage, RenderSettings(width=W, height=H, transparent=True))
        assert not [w for w in res.warnings if "subdivision" in w], res.warnings
        coverage.append(res.rgba[..., 3].sum())
    assert 0 < coverage[1] < 0.9 * coverage[0]
