"""Implicit surfaces (docs/stage_contract.md "Implicit surfaces"): the shapes the engine
makes of Sphere, Cube, Cylinder, Cone, Capsule, Plane, Cylinder_1 and Capsule_1, their
reading (axis, sizes, sharing, time samples, edits, sidedness, displayColor and
displayOpacity, materials, PointInstancer prototypes, render passes), and each type's
scene (tests/implicit_scenes.py) against Cycles through Blender's USD importer
(references/implicit/, made by references/make_prim_references.py):

- the silhouette within one pixel of the importer's render of the same file;
- HDR-FLIP against the exact shape's render (the matching mesh scene: the shapes as
  128-sided Mesh prims through the same importer) within the bound Lantern gets on
  that mesh scene itself (plus 10 % and 0.002);
- HDR-FLIP against the importer's render of the same file within that bound plus the
  importer's own distance from the exact shape (it tessellates with GeomUtil's ten
  sides: Cycles against Cycles).

Figures are printed (pytest -s shows them)."""
import functools
import math
import pathlib

import numpy as np
import pytest

import implicit_scenes
from image_masks import coverage_mask, over, silhouette_distance
from image_metrics import mean_flip

REFERENCES = pathlib.Path(__file__).resolve().parent / "references" / "implicit"
EXACT_SIDES = 128
PRESET = "high"


# --- the shapes ----------------------------------------------------------------------

def _stage():
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    return stage


CASES = [(kind, dict(zip(attrs, values))) for kind, attrs, values in [
    ("Sphere", ("radius",), (0.7,)),
    ("Cube", ("size",), (1.3,)),
    *[("Cylinder", ("radius", "height", "axis"), (0.4, 1.5, a)) for a in "XYZ"],
    *[("Cone", ("radius", "height", "axis"), (0.5, 1.2, a)) for a in "XYZ"],
    *[("Capsule", ("radius", "height", "axis"), (0.3, 1.0, a)) for a in "XYZ"],
    *[("Plane", ("width", "length", "axis"), (1.0, 2.5, a)) for a in "XYZ"],
    *[("Cylinder_1", ("radiusTop", "radiusBottom", "height", "axis"), (0.2, 0.6, 1.4, a))
      for a in "XYZ"],
    *[("Capsule_1", ("radiusTop", "radiusBottom", "height", "axis"), (0.5, 0.2, 1.4, a))
      for a in "XYZ"],
]]


def _made(kind, attrs):
    from pxr import Usd
    from lantern.engine.usd import shapes
    stage = _stage()
    prim = stage.DefinePrim("/S", kind)
    for key, value in attrs.items():
        prim.GetAttribute(key).Set(value)
    _made.stages.append(stage)              # the prim lives as long as its stage
    return prim, shapes.surface(shapes.parameters(prim, Usd.TimeCode.Default()))


_made.stages = []


@pytest.mark.parametrize("kind,attrs", CASES, ids=[f"{k}-{a.get('axis', '')}" for k, a in CASES])
def test_shape_fills_the_extent_usd_computes(kind, attrs):
    """USD's own extent of the schema (UsdGeom's extent plugins: sizes and axis
    conventions) is the made triangles' box."""
    from pxr import Usd, UsdGeom
    prim, surface = _made(kind, attrs)
    extent = np.array(UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(prim),
                                                                 Usd.TimeCode.Default()))
    lo, hi = surface.points.min(axis=0), surface.points.max(axis=0)
    size = float(np.linalg.norm(extent[1] - extent[0]))
    # Round shapes are polygons of SEGMENTS sides inside their circles.
    tolerance = size * (1 - math.cos(math.pi / 48)) + 1e-9
    if kind == "Capsule_1":
        # USD's extent plugin gives both ends the larger radius; Hydra's shape (a
        # cone of those end radii capped by the spheres tangent to it) reaches
        # further: each cap sphere's radius is its end's over cos(lean).
        axis = "XYZ".index(attrs["axis"])
        half, rb, rt = attrs["height"] / 2, attrs["radiusBottom"], attrs["radiusTop"]
        lean = math.atan2(rb - rt, attrs["height"])
        big_b, big_t = rb / math.cos(lean), rt / math.cos(lean)
        wide = max(big_b, big_t)
        extent = np.array([[-wide] * 3, [wide] * 3])
        extent[0][axis] = -half - big_b * math.sin(lean) - big_b
        extent[1][axis] = half - big_t * math.sin(lean) + big_t
    assert np.allclose(lo, extent[0], atol=tolerance), (lo, extent[0])
    assert np.allclose(hi, extent[1], atol=tolerance), (hi, extent[1])


@pytest.mark.parametrize("kind,attrs", CASES, ids=[f"{k}-{a.get('axis', '')}" for k, a in CASES])
def test_faces_wind_outwards_with_unit_normals(kind, attrs):
    _, s = _made(kind, attrs)
    assert np.allclose(np.linalg.norm(s.normals, axis=1), 1.0)
    offsets = np.concatenate([[0], np.cumsum(s.counts)])
    for f in range(len(s.counts)):
        corner = s.indices[offsets[f]:offsets[f + 1]]
        p = s.points[corner]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        if np.linalg.norm(n) < 1e-12:            # a quad's collapsed edge at a pole
            n = np.cross(p[2] - p[0], p[-1] - p[0])
        if np.linalg.norm(n) < 1e-12:
            continue
        assert np.dot(n, s.normals[corner].mean(axis=0)) > 0, (kind, f)


def _distance_to_sphere(p, centre, r):
    return np.abs(np.linalg.norm(p - centre, axis=1) - r)


def test_capsule_1_points_lie_on_its_spheres_and_their_tangent_cone():
    """A Capsule_1 whose radii differ is the cone of those end radii, `height` long,
    capped by the spheres tangent to it: every point is on one of them, with its
    normal, and the rings at the cone's ends have the authored radii. The sizes are
    Hydra's own (USD 25.08's GeomUtil, through Blender's importer): a 0.6 to 0.2
    capsule 2 long reaches 1.7319 below its centre and 1.1640 above."""
    _, s = _made("Capsule_1", {"radiusTop": 0.2, "radiusBottom": 0.6, "height": 2.0,
                               "axis": "Z"})
    lean = math.atan2(0.4, 2.0)
    rb, rt = 0.6 / math.cos(lean), 0.2 / math.cos(lean)
    cb, ct = np.array([0, 0, -1 - rb * math.sin(lean)]), np.array([0, 0, 1 - rt * math.sin(lean)])
    low, high = _distance_to_sphere(s.points, cb, rb), _distance_to_sphere(s.points, ct, rt)
    assert (np.minimum(low, high) < 1e-9).all()
    on_low = low < 1e-9
    assert np.allclose(s.normals[on_low], (s.points[on_low] - cb) / rb)
    assert s.points[:, 2].min() == pytest.approx(-1.7319, abs=1e-4)
    assert s.points[:, 2].max() == pytest.approx(1.1640, abs=1e-4)
    for z, r in ((-1.0, 0.6), (1.0, 0.2)):
        ring = np.isclose(s.points[:, 2], z)
        assert np.allclose(np.hypot(*s.points[ring, :2].T), r)


# --- reading -------------------------------------------------------------------------

def _session(stage, **settings):
    from lantern.engine import RenderSettings, Session
    settings = {"width": 48, "height": 32, "preset": "low", **settings}
    return Session(stage, RenderSettings(**settings))


def test_prims_of_equal_sizes_share_one_mesh_and_an_edit_remakes_it():
    from pxr import UsdGeom
    stage = _stage()
    for i in range(3):
        UsdGeom.Sphere.Define(stage, f"/S{i}").CreateRadiusAttr(0.5)
    with _session(stage) as session:
        session.render()
        assert len(session.scene.instances) == 3 and len(session.scene.meshes) == 1
        UsdGeom.Sphere(stage.GetPrimAtPath("/S1")).GetRadiusAttr().Set(2.0)
        session.render()
        keys = {session.scene.instances[f"/S{i}"].mesh_key for i in range(3)}
        assert len(keys) == 2
        lo, hi = session.scene.meshes[session.scene.instances["/S1"].mesh_key].bounds
        assert np.allclose(hi - lo, 4.0, atol=1e-2)


def test_a_time_sampled_radius_is_read_at_each_frame():
    from pxr import UsdGeom
    stage = _stage()
    radius = UsdGeom.Sphere.Define(stage, "/S").CreateRadiusAttr()
    radius.Set(1.0, 1.0)
    radius.Set(3.0, 3.0)
    with _session(stage) as session:
        for frame, r in ((1.0, 1.0), (2.0, 2.0), (3.0, 3.0)):
            session.render(frame=frame)
            lo, hi = session.scene.meshes[session.scene.instances["/S"].mesh_key].bounds
            assert np.isclose(hi[2], r, atol=1e-6)


def test_malformed_shape_is_one_warning_and_skipped():
    from pxr import UsdGeom
    stage = _stage()
    UsdGeom.Cylinder.Define(stage, "/C").CreateRadiusAttr(-1.0)
    UsdGeom.Cube.Define(stage, "/B")
    with _session(stage) as session:
        result = session.render()
    assert "/C" not in session.scene.instances and "/B" in session.scene.instances
    assert [w for w in result.warnings if w.startswith("/C:")] == \
        ["/C: malformed mesh (radius -1.0 is not a finite size of zero or more); skipped"]


def test_display_color_opacity_sidedness_and_material_as_meshes_have_them():
    from pxr import Gf, Sdf, UsdGeom, UsdShade
    stage = _stage()
    s = UsdGeom.Sphere.Define(stage, "/Coloured")
    s.CreateDisplayColorAttr([Gf.Vec3f(0.1, 0.6, 0.2)])
    s.CreateDisplayOpacityAttr([0.4])
    p = UsdGeom.Plane.Define(stage, "/Plane")
    c = UsdGeom.Cube.Define(stage, "/Bound")
    c.CreateDoubleSidedAttr(True)
    material = UsdShade.Material.Define(stage, "/M")
    shader = UsdShade.Shader.Define(stage, "/M/S")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(1.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(c.GetPrim()).Bind(material)
    with _session(stage) as session:
        session.render()
        scene = session.scene
        mesh = lambda path: scene.meshes[scene.instances[path].mesh_key]  # noqa: E731
        coloured = scene.materials[mesh("/Coloured").materials[0]]
        assert np.allclose(coloured.diffuse, (0.1, 0.6, 0.2)) and coloured.opacity == \
            pytest.approx(0.4) and coloured.alpha == "blend"
        assert mesh("/Plane").double_sided and not mesh("/Coloured").double_sided
        assert mesh("/Bound").materials == ["/M"] and scene.materials["/M"].metallic == 1.0


def test_a_point_instancer_of_implicit_prototypes_draws_each_instance():
    from pxr import Gf, UsdGeom
    stage = _stage()
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    UsdGeom.Sphere.Define(stage, "/PI/Protos/Ball").CreateRadiusAttr(0.25)
    UsdGeom.Cone.Define(stage, "/PI/Protos/Cone")
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Ball", "/PI/Protos/Cone"])
    pi.CreateProtoIndicesAttr([0, 1, 0])
    pi.CreatePositionsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(2, 0, 0), Gf.Vec3f(4, 0, 0)])
    with _session(stage) as session:
        result = session.render()
    batches = {p: i for p, i in session.scene.instances.items() if p.startswith("/PI{")}
    assert sorted(len(i.worlds) for i in batches.values()) == [1, 2]
    assert result.stats["instances_drawn"] >= 3 and not result.warnings


def test_a_prototype_drawn_many_times_has_fewer_sides():
    """A sphere alone has 48 sides (2,208 triangles); a prototype drawn 2,000 times
    16 (224 triangles), within the triangle budget of a prototype."""
    from pxr import Gf, UsdGeom
    from lantern.engine.usd import shapes
    stage = _stage()
    UsdGeom.Sphere.Define(stage, "/Alone")
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    UsdGeom.Sphere.Define(stage, "/PI/Protos/Ball")
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Ball"])
    pi.CreateProtoIndicesAttr([0] * 2000)
    pi.CreatePositionsAttr([Gf.Vec3f(3 * (i % 50), 3 * (i // 50), 0) for i in range(2000)])
    with _session(stage) as session:
        session.render()
    triangles = {path: session.scene.meshes[inst.mesh_key].index_count // 3
                 for path, inst in session.scene.instances.items()}
    assert triangles == {"/Alone": 2208, "/PI{/PI/Protos/Ball}": 224}
    assert shapes.segments_for(2000) == 16 and 2000 * 224 <= shapes.TRIANGLES_PER_PROTOTYPE


def test_prototypes_under_an_over_are_drawn_as_instances_only():
    """OpenUSD's own instancing tests keep prototypes under an `over` (undefined, so
    never drawn by themselves): the instancer draws them."""
    from pxr import Usd
    stage = Usd.Stage.CreateInMemory()
    stage.GetRootLayer().ImportFromString("""#usda 1.0
def PointInstancer "PI" {
    point3f[] positions = [(0, 0, 0), (3, 0, 0)]
    int[] protoIndices = [0, 0]
    rel prototypes = [</PI/Protos/Ball>]
    over "Protos" {
        def Sphere "Ball" {}
    }
}""")
    assert not stage.GetPrimAtPath("/PI/Protos/Ball").IsDefined()
    with _session(stage) as session:
        result = session.render()
    assert [len(i.worlds) for p, i in session.scene.instances.items()] == [2]
    assert not result.warnings, result.warnings


def test_object_index_and_depth_passes_hold_implicit_surfaces():
    from pxr import Gf, UsdGeom
    stage = _stage()
    s = UsdGeom.Sphere.Define(stage, "/S")
    s.GetPrim().CreateAttribute("lantern:passIndex", __import__("pxr").Sdf.ValueTypeNames.Int).Set(7)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    with _session(stage, passes=("IndexOB", "Depth"), width=32, height=32) as session:
        result = session.render()
    index, depth = result.passes["IndexOB"][..., 0], result.passes["Depth"][..., 0]
    assert index[16, 16] == 7 and index[0, 0] == 0
    assert depth[16, 16] == pytest.approx(4.0, abs=0.02)     # the sphere's front at z = 1


# --- against Cycles ------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _lantern(name, as_mesh, tmp):
    from lantern.engine import RenderSettings, render_file
    path = pathlib.Path(tmp) / f"{name}{'_mesh' if as_mesh else ''}.usda"
    implicit_scenes.write_stage(name, path, as_mesh=as_mesh,
                                segments=EXACT_SIDES if as_mesh else None)
    w, h = implicit_scenes.SIZE
    result = render_file(str(path), RenderSettings(width=w, height=h, preset=PRESET,
                                                   transparent=True))
    assert not result.warnings, result.warnings
    return result.rgba.astype(np.float64)


def _reference(name):
    from lantern.engine import read_exr
    return read_exr(str(REFERENCES / f"{name}.exr")).astype(np.float64)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return str(tmp_path_factory.mktemp("implicit"))


@pytest.mark.parametrize("name", sorted(implicit_scenes.SCENES))
def test_implicit_scene_against_cycles(name, workdir):
    world = implicit_scenes.WORLD
    implicit = _lantern(name, False, workdir)
    as_mesh = _lantern(name, True, workdir)
    importer, exact = _reference(name), _reference(f"{name}_mesh{EXACT_SIDES}")
    silhouette = silhouette_distance(coverage_mask(implicit), coverage_mask(importer))
    mesh_bound = mean_flip(over(as_mesh, world), over(exact, world))
    against_exact = mean_flip(over(implicit, world), over(exact, world))
    against_importer = mean_flip(over(implicit, world), over(importer, world))
    importer_error = mean_flip(over(importer, world), over(exact, world))
    print(f"{name}: silhouette {silhouette:.2f} px from the importer's; FLIP {against_exact:.4f} "
          f"against the exact shape (the mesh scene's {mesh_bound:.4f}), {against_importer:.4f} "
          f"against the importer's (its own distance from the exact shape {importer_error:.4f})")
    assert silhouette <= 1.0
    assert against_exact <= 1.1 * mesh_bound + 0.002
    assert against_importer <= mesh_bound + importer_error + 0.002
