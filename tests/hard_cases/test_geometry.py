"""Geometry: polygons become triangles that cover exactly the polygon (never a fan of a
concave polygon), and the exported mesh matches Blender's evaluated mesh.

Measured against Blender's own loop triangles of the same evaluated mesh: positions
within 1e-5 of the bounding-box diagonal, triangle coverage within 1e-5 of the
diagonal squared (areas), and the same coverage on a grid of sample points."""
import numpy as np
import pytest

from lantern.core.triangulate import triangulate

BOUND = 1e-5

# An L whose corner 0 cannot see corner 2 through the L: a fan from corner 0 leaves it.
L_SHAPE = [(2, 1), (1, 1), (1, 2), (0, 2), (0, 0), (2, 0)]
# A square with a square hole, as one ring: the outer ring, a bridge to the hole
# (duplicated corners at the same places), the hole backwards, and back.
KEYHOLE = [(0, 0), (4, 0), (4, 4), (0, 4), (0, 0), (1, 1), (1, 3), (3, 3), (3, 1), (1, 1)]
STAR = [(np.cos(a) * r, np.sin(a) * r) for a, r in
        zip(np.linspace(0, 2 * np.pi, 10, endpoint=False) + np.pi / 2, [2, 0.8] * 5)]
COLLINEAR = [(0, 0), (1, 0), (2, 0), (2, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
AREAS = {"L": 3.0, "keyhole": 12.0, "collinear": 4.0}


def _ring(xy, z=0.0):
    return np.array([(x, y, z) for x, y in xy], np.float64)


def _signed_areas(points, tris, normal):
    a, b, c = points[tris[:, 0]], points[tris[:, 1]], points[tris[:, 2]]
    return 0.5 * np.cross(b - a, c - a) @ normal


def _coverage(points2d, tris, samples):
    """How many triangles cover each sample point (2D)."""
    a, b, c = (points2d[tris[:, i]][:, None, :] for i in range(3))
    p = samples[None, :, :]

    def edge(u, v):
        return (v[..., 0] - u[..., 0]) * (p[..., 1] - u[..., 1]) - \
               (v[..., 1] - u[..., 1]) * (p[..., 0] - u[..., 0])
    e0, e1, e2 = edge(a, b), edge(b, c), edge(c, a)
    inside = ((e0 >= 0) & (e1 >= 0) & (e2 >= 0)) | ((e0 <= 0) & (e1 <= 0) & (e2 <= 0))
    degenerate = np.abs(edge(a, b) + edge(b, c) + edge(c, a)) == 0
    return (inside & ~degenerate).sum(axis=0)


def _grid(points2d, n=97):
    lo, hi = points2d.min(0), points2d.max(0)
    # Offsets keep samples off the polygons' edges and diagonals.
    xs = lo[0] + (np.arange(n) + 0.5 + 0.0137) / n * (hi[0] - lo[0])
    ys = lo[1] + (np.arange(n) + 0.5 + 0.0291) / n * (hi[1] - lo[1])
    return np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)


def _fan(count):
    return np.array([(0, k, k + 1) for k in range(1, count - 1)], np.int64)


@pytest.mark.parametrize("name, ring", [("L", L_SHAPE), ("keyhole", KEYHOLE),
                                        ("collinear", COLLINEAR)])
def test_triangles_cover_the_polygon_exactly(name, ring, hard_case):
    points = _ring(ring)
    corners, face = triangulate(points, [len(points)], np.arange(len(points)))
    assert (face == 0).all() and corners.min() >= 0 and corners.max() < len(points)
    areas = _signed_areas(points, corners, np.array([0, 0, 1.0]))
    assert (areas >= -1e-12).all(), "a triangle is wound against its polygon"
    diag = float(np.linalg.norm(points.max(0) - points.min(0)))
    hard_case(f"{name} polygon: |Σ|triangle area| − polygon area| / diag²",
              abs(np.abs(areas).sum() - AREAS[name]) / diag ** 2, BOUND)
    cover = _coverage(points[:, :2], corners, _grid(points[:, :2]))
    inside = _coverage(points[:, :2], _reference_triangles(name), _grid(points[:, :2]))
    hard_case(f"{name} polygon: grid samples covered differently from the polygon",
              int((cover != inside).sum()), 0)


def _reference_triangles(name):
    """Hand-made triangulations of the test polygons, to compare coverage with."""
    if name == "L":
        return np.array([(4, 5, 0), (4, 0, 1), (4, 1, 3), (1, 2, 3)])
    if name == "keyhole":  # outer square minus the hole, as 8 triangles
        return np.array([(0, 1, 8), (0, 8, 5), (1, 2, 7), (1, 7, 8), (2, 3, 6), (2, 6, 7),
                         (3, 0, 5), (3, 5, 6)])
    return np.array([(0, 2, 4), (0, 4, 6)])


def test_a_fan_of_the_concave_shapes_fails_the_same_checks():
    """Negative control: the checks above catch a fan (what the engine does today)."""
    for ring, area in ((L_SHAPE, AREAS["L"]), (KEYHOLE, AREAS["keyhole"])):
        points = _ring(ring)
        fan = _fan(len(points))
        areas = _signed_areas(points, fan, np.array([0, 0, 1.0]))
        diag = float(np.linalg.norm(points.max(0) - points.min(0)))
        assert abs(np.abs(areas).sum() - area) / diag ** 2 > 100 * BOUND


def test_star_is_wound_like_the_polygon_in_any_plane():
    """The star rotated onto a tilted plane, both windings: best-fit plane projection."""
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    up = q @ np.array([0, 0, 1.0])
    for ring, normal in ((STAR, up), (STAR[::-1], -up)):
        points = _ring(ring) @ q.T + np.array([1e5, -2e5, 3e5])
        corners, face = triangulate(points, [10], np.arange(10))
        assert len(corners) == 8
        areas = _signed_areas(points, corners, normal)
        assert (areas > 0).all()
        star_area = 5 * 2 * 0.5 * 2 * 0.8 * np.sin(np.pi / 5)
        assert abs(areas.sum() - star_area) < 1e-6


def test_mixed_mesh_keeps_face_order_and_corner_positions():
    # A triangle, a convex quad, a concave (dart) quad needing the 1-3 split, an L.
    points = np.array([(0, 0, 0), (1, 0, 0), (0, 1, 0),
                       (2, 0, 0), (3, 0, 0), (3, 1, 0), (2, 1, 0),
                       (4, 0, 0), (5, 0.5, 0), (6, 0, 0), (5, 2, 0)] +
                      [(x + 7, y, 0) for x, y in L_SHAPE], np.float64)
    counts = [3, 4, 4, 6]
    # The dart 8, 9, 10, 7 written from its corner 8 backwards: its reflex corner (8)
    # is corner 3, so the 0-2 diagonal runs outside and the quad goes to earcut.
    indices = [0, 1, 2, 3, 4, 5, 6] + [9, 10, 7, 8] + list(range(11, 17))
    corners, face = triangulate(points, counts, indices)
    assert face.tolist() == sorted(face.tolist()) == [0, 1, 1, 2, 2, 3, 3, 3, 3]
    idx = np.array(indices)
    areas = _signed_areas(points, idx[corners], np.array([0, 0, 1.0]))
    assert (areas > 0).all()
    assert corners[:3].tolist() == [[0, 1, 2], [3, 4, 5], [3, 5, 6]]  # Blender's quad split


def test_degenerate_polygons_never_raise():
    points = np.array([(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 0, 0), (np.nan, 0, 0)], float)
    # a two-corner face, a line, a point repeated, a NaN corner, an empty face list
    for counts, indices in (([2], [0, 1]), ([3], [0, 1, 2]), ([4], [0, 3, 0, 3]),
                            ([5], [0, 1, 2, 3, 4]), ([4], [0, 1, 4, 2]), ([], [])):
        corners, face = triangulate(points, counts, indices)
        assert corners.dtype == np.int64 and face.dtype == np.int64
        assert len(corners) == len(face)
        if len(corners):
            assert corners.min() >= 0 and corners.max() < len(indices)


def test_ten_thousand_quads_take_the_vectorized_path():
    """A 100×100 grid: speed sanity (no timing assert), and the exact count."""
    n = 101
    xs, ys = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    points = np.stack([xs.ravel(), ys.ravel(), np.sin(xs.ravel()) * 0.01], 1)
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    quads = np.stack([a, a + 1, a + n + 1, a + n], 1)
    corners, face = triangulate(points, np.full(len(quads), 4), quads.ravel())
    assert len(corners) == 2 * len(quads)
    assert (np.bincount(face) == 2).all()


# --- against Blender's evaluated mesh ---------------------------------------------------

def _blender_polygon(ring, name):
    import bpy
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, p)) for p in _ring(ring)], [], [list(range(len(ring)))])
    mesh.update()
    ob = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(ob)
    ob.rotation_euler = (0.4, -0.3, 0.9)
    ob.location = (3.0, -2.0, 1.0)
    return ob


@pytest.mark.parametrize("name, ring", [("L", L_SHAPE), ("keyhole", KEYHOLE),
                                        ("star", STAR)])
def test_exported_polygon_matches_blenders_loop_triangles(empty_scene, name, ring, hard_case):
    import bpy
    from pxr import UsdGeom
    from _export_helpers import export_current, vectors
    ob = _blender_polygon(ring, name)
    stage, _ = export_current()
    mesh = UsdGeom.Mesh(next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)))
    points = np.array(mesh.GetPointsAttr().Get(), np.float64)
    counts = np.array(mesh.GetFaceVertexCountsAttr().Get())
    indices = np.array(mesh.GetFaceVertexIndicesAttr().Get())

    data = ob.data
    data.calc_loop_triangles()
    blender_points = vectors(data.vertices, "co").astype(np.float64)
    blender_tris = vectors(data.loop_triangles, "vertices", 3).astype(np.int64)
    blender_area = sum(t.area for t in data.loop_triangles)
    diag = float(np.linalg.norm(blender_points.max(0) - blender_points.min(0)))

    hard_case(f"{name} polygon: exported points vs Blender's / diag",
              np.abs(points - blender_points).max() / diag, BOUND)
    corners, _ = triangulate(points, counts, indices)
    tris = indices[corners]
    normal = np.array([0, 0, 1.0])
    areas = _signed_areas(points, tris, normal)
    assert (areas >= -1e-12).all()
    hard_case(f"{name} polygon: Σ triangle area vs Blender's loop triangles / diag²",
              abs(np.abs(areas).sum() - blender_area) / diag ** 2, BOUND)
    samples = _grid(points[:, :2])
    ours = _coverage(points[:, :2], tris, samples)
    theirs = _coverage(blender_points[:, :2], blender_tris, samples)
    hard_case(f"{name} polygon: grid samples covered differently from Blender's",
              int((ours != theirs).sum()), 0)
    assert bpy.context.scene.objects[name].type == "MESH"


def _polygon_stage(points, counts, indices):
    """One mesh seen from above by an orthographic camera that frames it."""
    from pxr import Gf, Usd, UsdGeom, Vt
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    mesh = UsdGeom.Mesh.Define(stage, "/Shape")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([int(c) for c in counts]))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for i in indices]))
    mesh.CreateDoubleSidedAttr(True)
    camera = UsdGeom.Camera.Define(stage, "/Camera")
    camera.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    camera.CreateHorizontalApertureAttr(48.0)   # tenths of a unit: 4.8 units wide
    camera.CreateVerticalApertureAttr(48.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100))
    camera.AddTranslateOp().Set(Gf.Vec3d(1.0, 1.0, 10.0))
    return stage


def test_engine_covers_the_concave_polygon_exactly():
    """The L rendered as one polygon covers the same pixels as the L cut by
    core.triangulate beforehand (the engine has nothing left to cut)."""
    from lantern.engine import RenderSettings, render_stage
    points = _ring(L_SHAPE)
    corners, _ = triangulate(points, [6], np.arange(6))
    settings = RenderSettings(width=64, height=64, transparent=True)
    polygon = render_stage(_polygon_stage(points, [6], range(6)), settings).rgba[..., 3]
    cut = render_stage(_polygon_stage(points, [3] * len(corners), corners.ravel()),
                       settings).rgba[..., 3]
    assert (cut > 0.5).sum() > 500, "the reference covers the L"
    assert int(((polygon > 0.5) != (cut > 0.5)).sum()) == 0
