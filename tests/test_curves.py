"""Curves (docs/stage_contract.md "Curves"): BasisCurves of every basis and wrap and
NurbsCurves sampled as USD defines them (against Blender's own evaluation of the same
curves, and against closed forms), widths and normals by interpolation, the round
tubes and oriented ribbons they are drawn as, shadows cast and received, and the
curves scene (tests/curve_scenes.py) against Cycles (references/curves/, made by
references/make_prim_references.py --curves): each curve's cell within FLIP_TUBES
where Cycles and Lantern both draw round tubes, FLIP_RIBBONS where Lantern draws the
authored normals' ribbons (Cycles has no oriented ribbons: it draws tubes there too).

Figures are printed (pytest -s shows them)."""
import functools
import math
import pathlib

import numpy as np
import pytest

import curve_scenes
from image_masks import over
from image_metrics import mean_flip

REFERENCE = pathlib.Path(__file__).resolve().parent / "references" / "curves" / "curves.exr"
FLIP_TUBES = 0.06
FLIP_RIBBONS = 0.12
PRESET = "high"


def _stage():
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    return stage


def _curves(stage, path, points, counts, kind="cubic", basis="bspline", wrap="nonperiodic",
            widths=None, interp=None):
    from pxr import Gf, UsdGeom
    c = UsdGeom.BasisCurves.Define(stage, path)
    c.CreateTypeAttr(kind)
    c.CreateBasisAttr(basis)
    c.CreateWrapAttr(wrap)
    c.CreateCurveVertexCountsAttr(list(counts))
    c.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
    if widths is not None:
        c.CreateWidthsAttr(list(widths))
        c.SetWidthsInterpolation(interp)
    return c.GetPrim()


def _lines(prim):
    from pxr import Usd
    from lantern.engine.usd.curves import polylines
    return polylines(prim, Usd.TimeCode.Default())


# --- sampling ------------------------------------------------------------------------

def _polyline_distance(samples, points):
    """Largest distance from `points` to the polyline through `samples` (open)."""
    a, b = samples[:-1], samples[1:]
    ab = b - a
    t = np.clip(np.einsum("pij,ij->pi", points[:, None] - a[None], ab) /
                np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30), 0, 1)
    nearest = a[None] + t[..., None] * ab[None]
    return float(np.linalg.norm(points[:, None] - nearest, axis=2).min(axis=1).max())


@pytest.mark.parametrize("name", sorted(curve_scenes.CURVES))
def test_curve_samples_lie_on_blenders_evaluation_of_the_same_curve(name, tmp_path):
    """Blender evaluates each curve of the scene (its own Bezier, NURBS and poly types,
    built from the USD definition: curve_scenes.build_blender); every point it puts on
    the curve is within the sampling tolerance of Lantern's polyline, and its radius
    within 0.01 of Lantern's half width there (Blender interpolates radii between
    Bezier knots linearly, USD's vertex widths on a Catmull-Rom curve are cubic)."""
    from pxr import Usd
    curve_scenes.build_blender(evaluate=False)
    import bpy
    points, radii, cyclic = curve_scenes.evaluated(bpy.data.objects[name])
    stage = Usd.Stage.Open(str(curve_scenes.write_stage(tmp_path / "curves.usda")))
    lines = _lines(stage.GetPrimAtPath(f"/root/{name}"))
    samples = lines.points
    if lines.closed[0]:
        samples = np.concatenate([samples, samples[:1]])
    assert cyclic == bool(lines.closed[0])
    extent = np.linalg.norm(samples.max(axis=0) - samples.min(axis=0))
    distance = _polyline_distance(samples, points)
    nearest = np.argmin(np.linalg.norm(points[:, None] - samples[None], axis=2), axis=1)
    widths = np.concatenate([lines.widths, lines.widths[:1]]) if lines.closed[0] else lines.widths
    radius_error = float(np.abs(widths[nearest] / 2 - radii).max())
    print(f"{name}: {len(lines.points)} samples, {distance:.5f} from Blender's curve "
          f"({distance / extent:.1e} of its size), radius within {radius_error:.4f}")
    assert distance <= 1.5e-3 * extent
    assert radius_error <= 0.01


@pytest.mark.parametrize("basis,wrap,n,segments,first,last", [
    ("bezier", "nonperiodic", 7, 2, 0, 6),
    ("bezier", "periodic", 6, 2, 0, None),
    ("bspline", "nonperiodic", 6, 3, None, None),
    ("bspline", "periodic", 6, 6, None, None),
    ("bspline", "pinned", 6, 5, 0, 5),
    ("catmullRom", "nonperiodic", 6, 3, 1, 4),
    ("catmullRom", "periodic", 6, 6, 1, None),
    ("catmullRom", "pinned", 6, 5, 0, 5),
])
def test_each_basis_and_wrap_spans_what_usd_says(basis, wrap, n, segments, first, last):
    """USD's segment counts (varying widths: one a segment end) and end points: a
    pinned curve starts and ends on its end points, a nonperiodic Catmull-Rom runs
    from the second to the next-to-last, a periodic curve closes."""
    pts = [(math.cos(i), math.sin(1.7 * i), 0.1 * i) for i in range(n)]
    ends = segments + (0 if wrap == "periodic" else 1)
    stage = _stage()
    prim = _curves(stage, "/C", pts, [n], basis=basis, wrap=wrap,
                   widths=np.linspace(0.1, 0.2, ends), interp="varying")
    lines = _lines(prim)
    assert bool(lines.closed[0]) == (wrap == "periodic")
    if first is not None:
        assert np.allclose(lines.points[0], pts[first])
    if last is not None:
        assert np.allclose(lines.points[-1], pts[last])
    assert lines.widths[0] == pytest.approx(0.1)
    if wrap != "periodic":
        assert lines.widths[-1] == pytest.approx(0.2)


def test_bspline_samples_match_scipy_and_widths_interpolate_by_the_basis():
    """A nonperiodic cubic B-spline is the uniform B-spline over its points (scipy's,
    an independent evaluation); vertex widths follow the same basis."""
    from scipy.interpolate import BSpline
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(9, 3)).astype(np.float32).astype(np.float64)   # as stored
    widths = rng.uniform(0.05, 0.3, size=9).astype(np.float32).astype(np.float64)
    stage = _stage()
    lines = _lines(_curves(stage, "/C", pts, [9], widths=widths, interp="vertex"))
    spline = BSpline(np.arange(13.0), np.c_[pts, widths], 3)
    u = np.linspace(3.0, 9.0, 2001)
    exact = spline(u)
    assert _polyline_distance(lines.points, exact[:, :3]) < 2e-3 * np.ptp(pts, axis=0).max()
    at = spline(np.linspace(3.0, 9.0, len(lines.points)))       # ends agree exactly
    assert np.allclose(lines.points[[0, -1]], at[[0, -1], :3])
    assert np.allclose(lines.widths[[0, -1]], at[[0, -1], 3])


def test_rational_nurbs_circle_is_round():
    """A NurbsCurves circle (order 3, nine points with weights 1 and 1/sqrt 2, the
    textbook construction) samples at radius 1 everywhere."""
    from pxr import Gf, UsdGeom
    stage = _stage()
    c = UsdGeom.NurbsCurves.Define(stage, "/Circle")
    square = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)]
    c.CreatePointsAttr([Gf.Vec3f(x, y, 0) for x, y in square])
    c.CreateCurveVertexCountsAttr([9])
    c.CreateOrderAttr([3])
    c.CreateKnotsAttr([0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4])
    c.CreatePointWeightsAttr([1, 2 ** -0.5] * 4 + [1])
    c.CreateWidthsAttr([0.05])
    lines = _lines(c.GetPrim())
    r = np.linalg.norm(lines.points[:, :2], axis=1)
    assert np.allclose(r, 1.0, atol=1e-9) and len(lines.points) > 16
    assert np.allclose(lines.points[0], lines.points[-1])


def _nurbs_without_knots(stage, path, points, counts):
    """A NurbsCurves prim as OpenUSD's imaging tests author them: points and counts,
    no order or knots."""
    from pxr import Gf, UsdGeom
    c = UsdGeom.NurbsCurves.Define(stage, path)
    c.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
    c.CreateCurveVertexCountsAttr(list(counts))
    c.CreateWidthsAttr([0.3])
    return c.GetPrim()


ZIGZAG = [(-3, -2, 0), (-1, 1, 0), (1, -1, 0), (3, 2, 0), (-3, 3, 0), (3, 3.5, 0)]


def test_nurbs_curves_without_order_or_knots_are_drawn_through_their_control_points():
    """As Storm draws them: straight through their control points, each curve on its
    own; drawn exactly as the linear BasisCurves of the same points."""
    from pxr import Gf, UsdGeom
    stage = _stage()
    prim = _nurbs_without_knots(stage, "/N", ZIGZAG, [4, 2])
    lines = _lines(prim)
    assert np.allclose(lines.points, ZIGZAG) and list(lines.starts) == [0, 4, 6]
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0.5, 10))
    cam.CreateProjectionAttr("orthographic")
    cam.CreateHorizontalApertureAttr(80.0)
    cam.CreateVerticalApertureAttr(80.0)
    nurbs = _render(stage, transparent=True)
    stage.RemovePrim("/N")
    _curves(stage, "/B", ZIGZAG, [4, 2], kind="linear", widths=[0.3], interp="constant")
    linear = _render(stage, transparent=True)
    assert not nurbs.warnings, nurbs.warnings
    covered = nurbs.rgba[..., 3] > 0.5
    assert covered.sum() > 150                       # three zigzag pieces and a bar
    assert np.array_equal(covered, linear.rgba[..., 3] > 0.5)
    assert np.abs(nurbs.rgba - linear.rgba).max() < 1e-6


def test_widths_by_every_interpolation_and_malformed_curves_warn():
    from lantern.engine import RenderSettings, Session
    stage = _stage()
    pts = [(0, 0, 0), (1, 1, 0), (2, 0, 0), (3, 1, 0)] * 2
    _curves(stage, "/Uniform", pts, [4, 4], widths=[0.1, 0.3], interp="uniform")
    _curves(stage, "/Constant", pts[:4], [4], widths=[0.2], interp="constant")
    _curves(stage, "/Default", pts[:4], [4])
    _curves(stage, "/Short", pts[:3], [3], basis="bezier")
    _curves(stage, "/Widths", pts[:4], [4], widths=[0.1, 0.2], interp="vertex")
    with Session(stage, RenderSettings(width=32, height=32, preset="low")) as session:
        result = session.render()
    clouds = session.scene.points
    radii = clouds["/Uniform"].radii
    assert np.allclose(radii[clouds["/Uniform"].points[:, 0] >= 0][:1], 0.05)
    assert np.allclose(np.unique(np.round(radii, 6)), [0.05, 0.15])
    assert np.allclose(clouds["/Constant"].radii, 0.1)
    assert np.allclose(clouds["/Default"].radii, 0.5)         # unauthored: 1 wide, as Storm
    warned = sorted(w for w in result.warnings if w.startswith(("/Short", "/Widths")))
    assert warned == [
        "/Short: malformed curves (a nonperiodic bezier curve of 3 vertices (4, 7, 10, ...)); "
        "skipped",
        "/Widths: malformed curves (widths has 2 vertex values for 4); skipped"]


def test_ribbons_face_their_normals_and_keep_their_width_at_corners():
    from pxr import Gf, Usd, UsdGeom
    from lantern.engine.usd.curve_shapes import ribbon_surface
    stage = _stage()
    prim = _curves(stage, "/R", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3], kind="linear",
                   widths=[0.2], interp="constant")
    UsdGeom.BasisCurves(prim).CreateNormalsAttr([Gf.Vec3f(0, 0, 1)])
    UsdGeom.BasisCurves(prim).SetNormalsInterpolation("constant")
    s = ribbon_surface(prim, Usd.TimeCode.Default())
    quads = s.points.reshape(-1, 4, 3)
    for q, n in zip(quads, s.normals.reshape(-1, 4, 3)):
        face = np.cross(q[1] - q[0], q[2] - q[0])
        assert np.dot(face, n[0]) > 0 and np.allclose(n, (0, 0, 1))
        assert np.allclose(np.linalg.norm(q[1] - q[0]), 0.2)    # square to its own piece


# --- drawing -------------------------------------------------------------------------

def _render(stage, **settings):
    from lantern.engine import RenderSettings, render_stage
    return render_stage(stage, RenderSettings(**{"width": 64, "height": 64, "preset": "low",
                                                 **settings}))


def _quad(stage, path, x0, x1, y0, y1, z):
    from pxr import UsdGeom
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreateSubdivisionSchemeAttr("none")
    m.CreatePointsAttr([(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    return m


def _visible(stage, path, shown):
    from pxr import UsdGeom
    UsdGeom.Imageable(stage.GetPrimAtPath(path)).GetVisibilityAttr().Set(
        UsdGeom.Tokens.inherited if shown else UsdGeom.Tokens.invisible)


def test_tubes_cast_and_receive_shadows():
    """Seen from above: a tube 2 over a ground darkens the ground beside it where the
    tilted sun's shadow falls; a plate above the camera, over the left half, darkens
    the tube's left half and leaves its right half as it was."""
    from pxr import Gf, UsdGeom, UsdLux
    stage = _stage()
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set(Gf.Vec3d(0, 0, 8))
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(3.0)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(20, 0, 0))
    _quad(stage, "/Ground", -6, 6, -6, 6, -2)
    _curves(stage, "/Tube", [(-2, 0, 0), (2, 0, 0)], [2], kind="linear",
            widths=[0.4], interp="constant")
    _quad(stage, "/Plate", -6, 0, -6, 6, 10)
    _visible(stage, "/Plate", False)
    base = _render(stage).rgba[..., :3].mean(axis=2)
    _visible(stage, "/Ground", False)
    tube = _render(stage, transparent=True).rgba[..., 3] > 0.5
    _visible(stage, "/Ground", True)
    _visible(stage, "/Tube", False)
    no_tube = _render(stage).rgba[..., :3].mean(axis=2)
    shadow = (base < 0.5 * no_tube) & ~tube
    assert shadow.sum() >= 30 and tube.sum() >= 30
    rows = np.nonzero(shadow)[0]
    assert abs(rows.mean() - np.nonzero(tube)[0].mean()) >= 3    # beside the tube, not under it
    _visible(stage, "/Tube", True)
    _visible(stage, "/Plate", True)
    under_plate = _render(stage).rgba[..., :3].mean(axis=2)
    left, right = tube & (np.arange(64) < 28)[None], tube & (np.arange(64) > 36)[None]
    assert under_plate[left].mean() < 0.5 * base[left].mean()
    assert under_plate[right].mean() == pytest.approx(base[right].mean(), rel=0.05)


@functools.lru_cache(maxsize=None)
def _scene_render(tmp):
    from lantern.engine import RenderSettings, render_file
    path = curve_scenes.write_stage(pathlib.Path(tmp) / "curves.usda")
    w, h = curve_scenes.SIZE
    result = render_file(str(path), RenderSettings(width=w, height=h, preset=PRESET,
                                                   transparent=True))
    assert not result.warnings, result.warnings
    return result.rgba.astype(np.float64)


def _cells():
    """{curve name: (rows, columns)} of each curve's cell in the image."""
    from pxr import Gf
    w, h = curve_scenes.SIZE
    eye, target, lens = curve_scenes.CAMERA
    view = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(0, 0, 1))
    half = 18.0 / lens                                       # tan of half the 36 mm width
    out = {}
    for i, name in enumerate(curve_scenes.CURVES):
        ox, oy = curve_scenes.cell_origin(i)
        px = []
        for sx in (-0.5, 0.5):
            for sy in (-0.5, 0.5):
                p = view.Transform(Gf.Vec3d(ox + sx * curve_scenes.CELL[0],
                                            oy + sy * curve_scenes.CELL[1], 0.0))
                x, y = p[0] / -p[2] / half, p[1] / -p[2] / half
                px.append(((x + 1) / 2 * w, h / 2 - y * w / 2))
        px = np.array(px)
        lo, hi = np.floor(px.min(axis=0)).astype(int), np.ceil(px.max(axis=0)).astype(int)
        out[name] = (slice(max(lo[1], 0), hi[1]), slice(max(lo[0], 0), hi[0]))
    return out


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return str(tmp_path_factory.mktemp("curves"))


def test_curves_scene_against_cycles(workdir):
    from lantern.engine import read_exr
    world = curve_scenes.WORLD
    ours = over(_scene_render(workdir), world)
    cycles = over(read_exr(str(REFERENCE)).astype(np.float64), world)
    flips = {name: mean_flip(ours[cell], cycles[cell]) for name, cell in _cells().items()}
    for name, flip in flips.items():
        print(f"{name}: FLIP {flip:.4f}{' (ribbon)' if name in curve_scenes.WITH_NORMALS else ''}")
    print(f"whole image: FLIP {mean_flip(ours, cycles):.4f}")
    for name, flip in flips.items():
        assert flip <= (FLIP_RIBBONS if name in curve_scenes.WITH_NORMALS else FLIP_TUBES), name


@pytest.mark.parametrize("max_gl", ["45", "33"])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_a_tube_is_as_wide_as_its_widths_under_either_projection(projection, max_gl,
                                                                  monkeypatch):
    """A tube 0.5 wide (0.25 at one end) across the view of a camera 10 above it:
    its coverage per column is its width in pixels, to a pixel, on the GL 4.5 and
    GL 3.3 paths."""
    from pxr import Gf, UsdGeom
    monkeypatch.setenv("LANTERN_MAX_GL", max_gl)
    stage = _stage()
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    cam.CreateHorizontalApertureAttr(40.0)
    cam.CreateVerticalApertureAttr(40.0)
    if projection == "orthographic":
        cam.CreateProjectionAttr("orthographic")       # apertures in tenths of a unit: 4 wide
    else:
        cam.CreateFocalLengthAttr(100.0)               # 4 wide at the tube, 10 away
    _curves(stage, "/Tube", [(-3, 0, 0), (3, 0, 0)], [2], kind="linear",
            widths=[0.5, 0.25], interp="vertex")
    rgba = _render(stage, transparent=True, width=128, height=128).rgba
    cover = rgba[..., 3].sum(axis=0)                   # pixels covered per column
    px = 128 / 4.0                                     # pixels a unit
    x = (np.arange(128) + 0.5) / px - 2.0              # each column's centre
    want = (0.5 + (0.25 - 0.5) * (x + 3) / 6) * px
    assert np.abs(cover - want).max() < 1.0, np.abs(cover - want).max()


def test_a_curve_with_too_few_vertices_is_left_out_and_the_rest_drawn():
    """OpenUSD's pinnedCurves test: a batch whose last curve has one vertex draws the
    others (their uniform colours kept) and says which it left out."""
    from pxr import Gf, UsdGeom
    from lantern.engine import RenderSettings, Session
    stage = _stage()
    pts = [(1, 0, 0), (0.7, 0.7, 0), (0, 1, 0), (-0.7, 0.7, 0), (-1, 0, 0),
           (1, -3, 0), (2, -2, 0), (3, -3, 0), (1, -6, 0), (2, -6, 0), (1, -9, 0)]
    prim = _curves(stage, "/C", pts, [5, 3, 2, 1], wrap="pinned",
                   widths=[0.05] * 11, interp="vertex")
    colours = UsdGeom.PrimvarsAPI(prim).CreatePrimvar("displayColor", __import__(
        "pxr").Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.uniform)
    colours.Set([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(0, 0, 1), Gf.Vec3f(1, 1, 0)])
    with Session(stage, RenderSettings(width=32, height=32, preset="low")) as session:
        result = session.render()
    cloud = session.scene.points["/C"]
    assert result.warnings == [
        "/C: 1 of 4 curves are not drawn (a pinned bspline curve of 1 vertex (2 at least))"]
    assert {tuple(c) for c in cloud.colours} == {(1, 0, 0), (0, 1, 0), (0, 0, 1)}
    assert np.allclose(cloud.points[0], pts[0]) and cloud.points[:, 1].min() == \
        pytest.approx(-6.0)


@pytest.mark.parametrize("ribbons", [False, True], ids=["tubes", "ribbons"])
def test_skinned_curves_and_implicit_surfaces_render_as_their_baked_twin(corpus, ribbons):
    """OpenUSD's UsdSkel bake test rig (lbs.usda) with only its BasisCurves and its
    rigidly skinned Sphere, Cube and Cylinder: UsdSkel skins the curves' points on the
    CPU; as tubes, the same pixels as UsdSkel's
    own BakeSkinning of the stage, to 1e-4), the implicit surfaces on the GPU as
    meshes are skinned. The cube, bound to two joints at half weight each, is up to
    7.7e-3 off the bake: its normals are skinned by the blended matrix, as a mesh's
    are, where the baked transform's inverse transpose turns them slightly otherwise."""
    from pxr import Gf, Usd, UsdGeom, UsdSkel
    from lantern.engine import RenderSettings, render_stage
    path = corpus / "usdskel" / "usd" / "usdSkel" / "testenv" / "testUsdSkelBakeSkinning" / \
        "lbs.usda"

    def stage(bake, implicit):
        s = Usd.Stage.CreateInMemory()
        s.GetRootLayer().TransferContent(Usd.Stage.Open(str(path)).Flatten())
        for prim in list(s.Traverse()):
            if prim.IsA(UsdGeom.Mesh) or prim.GetName() == "GroundTruth" or \
                    not implicit and prim.GetName() in ("Sphere", "Cube", "Cylinder"):
                prim.SetActive(False)
        curves = UsdGeom.BasisCurves(s.GetPrimAtPath("/Root/Curves"))
        curves.CreateWidthsAttr([0.05])
        cam = UsdGeom.Camera.Define(s, "/Cam")       # one view for both (not framed)
        cam.AddTransformOp().Set(Gf.Matrix4d().SetLookAt(
            Gf.Vec3d(5, -6, 6), Gf.Vec3d(1, 0.5, 0.5), Gf.Vec3d(0, 0, 1)).GetInverse())
        if ribbons:
            curves.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * 40)
        if bake:
            assert UsdSkel.BakeSkinning(s.Traverse(), Gf.Interval(s.GetStartTimeCode(),
                                                                  s.GetEndTimeCode()))
        return s

    if ribbons:
        settings = RenderSettings(width=48, height=48, frame=16.0, preset="low",
                                  camera="/Cam")
        warnings = render_stage(stage(False, False), settings).warnings
        assert [w for w in warnings if "skinned" in w] == [
            "/Root/Curves: skinned curves with normals: the ribbons face their rest-pose "
            "normals (normals are not skinned)"]
        return
    for implicit, bound in ((False, 1e-4), (True, 1e-2)):
        skinned, baked = stage(False, implicit), stage(True, implicit)
        for frame in (5.0, 16.0, 25.0):
            settings = RenderSettings(width=48, height=48, frame=frame, preset="low",
                                      ambient_occlusion=False, fxaa=False, camera="/Cam")
            a, b = render_stage(skinned, settings), render_stage(baked, settings)
            assert not [w for w in a.warnings if "skel" in w], a.warnings
            assert (np.abs(a.rgba - a.rgba.mean()) > 1e-3).sum() > 100
            assert np.abs(a.rgba - b.rgba).max() <= bound, (implicit, frame)
