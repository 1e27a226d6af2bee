"""Subdivision surfaces tessellated by the GPU: the Bezier patches (engine/bezier_patches.py)
against the limit surface, the tessellation pass's triangles against the patches, levels
that follow the view, no cracks, and the CPU path's image."""
import numpy as np
import pytest
from pxr import Sdf, UsdGeom
from scipy.spatial import cKDTree

from lantern.engine import RenderSettings, Session
from lantern.engine.bezier_patches import bezier_patches, evaluate
from lantern.engine.gpu.context import run_gl
from lantern.engine.subdivision import _edges, cage, limit_points, refine, vertex_rules
from test_engine_scenes import cube, new_stage

CUBE_POINTS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
CUBE_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


def _grid(n=4, boundary="edgeAndCorner"):
    pts = np.array([[x, y, np.sin(1.3 * x) * np.cos(0.7 * y)]
                    for y in range(n + 1) for x in range(n + 1)], float)
    faces = [[y * (n + 1) + x, y * (n + 1) + x + 1, (y + 1) * (n + 1) + x + 1,
              (y + 1) * (n + 1) + x] for y in range(n) for x in range(n)]
    return cage(pts, [4] * len(faces), np.ravel(faces), interpolate_boundary=boundary)


def _regular(c):
    """Quads whose four corners have four edges (and the grid's rule-consistent ones)."""
    quads = c.indices.reshape(-1, 4)
    rule, edges, _ = vertex_rules(c)
    valence = np.bincount(edges.ravel(), minlength=len(c.points))
    return ((valence[quads] == 4) & (rule[quads] == 0)).all(axis=1)


@pytest.mark.parametrize("name, levels", [("cube", 2), ("cube", 3), ("grid", 1), ("grid", 2)])
def test_patches_are_the_limit_surface_where_regular(name, levels):
    """A patch's centre and edge midpoints are the limit points of the next level's face
    and edge points (numbered after the parent's points and edges)."""
    base = cage(CUBE_POINTS, [4] * 6, np.ravel(CUBE_FACES)) if name == "cube" else _grid()
    c = refine(base, levels)
    patches = bezier_patches(c)
    n_v, n_e = len(c.points), len(_edges(c.counts, c.indices)[0])
    limit = limit_points(refine(c, 1))
    centre = np.linalg.norm(evaluate(patches, 0.5, 0.5) - limit[n_v + n_e + np.arange(len(patches))],
                            axis=1)
    first_edge = _edges(c.counts, c.indices)[1].reshape(-1, 4)[:, 0]
    edge = np.linalg.norm(evaluate(patches, 0.5, 0.0) - limit[n_v + first_edge], axis=1)
    corner = np.abs(evaluate(patches, 0.0, 0.0) - limit_points(c)[c.indices.reshape(-1, 4)[:, 0]])
    assert corner.max() < 1e-12
    exact = _regular(c) if name == "cube" else np.ones(len(patches), bool)  # Keep Corners grid
    assert exact.any()
    assert centre[exact].max() < 1e-12 and edge[exact].max() < 1e-12
    if name == "cube":     # around the cube's corners (three edges): close, not exact
        assert 1e-6 < centre[~exact].max() < 2e-3


def test_a_cages_topology_is_found_once_per_level(monkeypatch):
    """Refinement, the vertex rules, the limit points and the patches all ask for a
    cage's edges and each corner's edge: found once per cage (here the cage and its
    two levels), and the same as found afresh."""
    import lantern.engine.subdivision as subdivision
    calls = []
    monkeypatch.setattr(subdivision, "_edges",
                        lambda counts, indices: calls.append(len(counts)) or _edges(counts, indices))
    c = refine(cage(CUBE_POINTS, [4] * 6, np.ravel(CUBE_FACES), crease_pairs=[(0, 1)],
                    crease_sharpness=[1.5]), 2)
    patches = bezier_patches(c)
    assert calls == [6, 24, 96]
    edges, corner_edge = _edges(c.counts, c.indices)
    assert np.array_equal(subdivision.topology(c)[0], edges)
    assert np.array_equal(subdivision.topology(c)[1], corner_edge)
    assert np.isfinite(patches).all()


def test_neighbouring_patches_share_their_edge_curves():
    """No cracks at any tessellation: along every shared edge both patches give one curve."""
    c = refine(cage(CUBE_POINTS, [4] * 6, np.ravel(CUBE_FACES)), 1)
    patches = bezier_patches(c).reshape(-1, 4, 4, 3)
    quads = c.indices.reshape(-1, 4)
    rows = {0: patches[:, 0, :], 1: patches[:, :, 3], 2: patches[:, 3, ::-1], 3: patches[:, ::-1, 0]}
    curves = {}
    for f, quad in enumerate(quads):
        for i in range(4):
            a, b = int(quad[i]), int(quad[(i + 1) % 4])
            curve = rows[i][f]
            twin = curves.get((b, a))
            if twin is not None:
                assert np.array_equal(curve, twin[::-1])
            curves[(a, b)] = curve
    assert len(curves) == 4 * len(quads)


def _subdivided_cube(level=3, size=1.5):
    stage = new_stage()
    mesh = cube(stage, "/root/c/mesh", size=size)
    mesh.CreateSubdivisionSchemeAttr("catmullClark")
    mesh.GetPrim().CreateAttribute("lantern:subdivisionRenderLevel", Sdf.ValueTypeNames.Int,
                                   custom=True).Set(level)
    return stage


def _tessellated(session, key=None):
    r = session._renderer
    key = key or next(iter(r.tessellation.meshes))
    return run_gl(lambda gl: r.tessellation.read(key)), session.scene.meshes[key].patches


def test_tessellated_triangles_are_the_patches_at_the_cap():
    """A target finer than any edge cuts every patch edge `cap` times: the triangles'
    corners are the patches evaluated on that grid, with the UVs' own patches (across
    the cube's UV seams, every face its own piece of UV space), and their normals point
    out."""
    stage = _subdivided_cube(level=3)
    mesh = stage.GetPrimAtPath("/root/c/mesh")
    # Per face corner: each face its own square of UV space, so seams are everywhere.
    uv = [(f % 3 + x, f // 3 + y) for f in range(6) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                            UsdGeom.Tokens.faceVarying).Set(uv)
    with Session(stage, RenderSettings(width=64, height=48, tessellation_px=1e-3)) as s:
        res = s.render()
        assert res.stats["meshes_tessellated"] == 1
        data, patches = _tessellated(s)
    cap = patches.cap
    assert cap == 4                                  # render level 3, patches at level 2
    assert len(data) == patches.max_vertices         # 2 cap^2 triangles per patch
    t = np.linspace(0.0, 1.0, cap + 1)
    u, v = np.meshgrid(t, t)
    expected = evaluate(patches.control.astype(np.float64), u, v).reshape(-1, 3)
    expected_uv = evaluate(patches.uv.astype(np.float64), u, v).reshape(-1, 2)
    assert expected_uv.max() > 2.5                           # every face its own square
    ours = np.concatenate([data[:, :3], data[:, 6:8]], axis=1).astype(np.float64)
    dist, _ = cKDTree(np.concatenate([expected, expected_uv], axis=1)).query(ours)
    assert dist.max() < 2e-6
    back, _ = cKDTree(data[:, :3]).query(expected)
    assert back.max() < 2e-6
    # Normals point out of the (convex) shape, unit length.
    assert np.allclose(np.linalg.norm(data[:, 3:6], axis=1), 1.0, atol=1e-5)
    assert ((data[:, 3:6] * data[:, :3]).sum(axis=1) > 0).all()


def test_levels_follow_the_view_and_a_still_view_cuts_nothing():
    stage = _subdivided_cube(level=4)
    with Session(stage, RenderSettings(width=320, height=180)) as s:
        near = np.eye(4)
        near[2, 3] = -3.0         # world-to-view: the cube 3 units in front
        proj = np.array([[1.0, 0, 0, 0], [0, 16 / 9, 0, 0], [0, 0, -1.0002, -0.020002],
                         [0, 0, -1, 0]])
        s.render(view_matrix=near, projection_matrix=proj)
        n_near = len(_tessellated(s)[0])
        res = s.render(view_matrix=near, projection_matrix=proj)
        assert res.stats.get("meshes_tessellated", 0) == 0 and res.stats["bytes_uploaded"] == 0
        far = near.copy()
        far[2, 3] = -60.0
        res = s.render(view_matrix=far, projection_matrix=proj)
        assert res.stats["meshes_tessellated"] == 1
        n_far = len(_tessellated(s)[0])
        patches = s.scene.meshes[next(iter(s._renderer.tessellation.meshes))].patches
    assert n_far == 6 * len(patches.control)           # one quad per patch: 2 triangles
    assert 4 * n_far < n_near <= patches.max_vertices


def test_no_cracks_between_patches_cut_at_different_levels():
    """Seen up close in perspective, patches choose different levels; the triangles still
    close the surface: every edge of the closed shape is shared by exactly two triangles
    (a crack or a T-junction leaves edges used once)."""
    stage = _subdivided_cube(level=4, size=2.0)
    view = np.eye(4)
    view[:3, :3] = np.array([[0.8, -0.6, 0], [0.36, 0.48, 0.8], [-0.48, -0.64, 0.6]])
    view[2, 3] = -2.6
    proj = np.array([[1.2, 0, 0, 0], [0, 1.6, 0, 0], [0, 0, -1.0002, -0.020002], [0, 0, -1, 0]])
    with Session(stage, RenderSettings(width=192, height=144, tessellation_px=6.0)) as s:
        s.render(view_matrix=view, projection_matrix=proj)
        data, patches = _tessellated(s)
    assert 6 * len(patches.control) < len(data) < patches.max_vertices   # levels in between
    pts = data[:, :3].astype(np.float64)
    # One id per place: corners from two patches agree to float rounding.
    near = cKDTree(pts).query_ball_point(pts, r=1e-5)
    ids = np.array([min(n) for n in near]).reshape(-1, 3)
    edges = np.sort(np.concatenate([ids[:, [0, 1]], ids[:, [1, 2]], ids[:, [2, 0]]]), axis=1)
    edges = edges[edges[:, 0] != edges[:, 1]]
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert len(uses) > 1000 and (uses == 2).all(), np.bincount(uses)


@pytest.mark.parametrize("cpu_path", ["tessellation_px 0", "GL 3.3"])
def test_cpu_refinement_draws_the_same_image(monkeypatch, cpu_path):
    """tessellation_px 0, GL 3.3 and 4.1 refine on the CPU to the render level, with the
    limit step: the same surface, within the refinement's flat triangles."""
    images = []
    for tessellated in (True, False):
        px = 2.0 if tessellated or cpu_path == "GL 3.3" else 0.0
        if not tessellated and cpu_path == "GL 3.3":
            monkeypatch.setenv("LANTERN_MAX_GL", "33")
        with Session(_subdivided_cube(level=4), RenderSettings(width=160, height=120,
                                                              tessellation_px=px)) as s:
            res = s.render()
            assert ("tessellation" in res.stats["passes"]) == tessellated
            images.append(res.rgba)
    diff = np.abs(images[0] - images[1])[..., :3]
    assert diff.mean() < 2e-3
    assert (diff.max(axis=2) > 0.05).mean() < 0.01     # a silhouette pixel here and there


def test_a_high_render_level_caps_the_triangles_by_memory():
    from lantern.engine.usd.mesh import MAX_TESSELLATED_VERTICES

    with Session(_subdivided_cube(level=11), RenderSettings(width=64, height=48)) as s:
        s.render()
        patches = next(m.patches for m in s.scene.meshes.values())
    assert patches.cap < 2 ** 10
    assert patches.max_vertices <= MAX_TESSELLATED_VERTICES


def test_stencils_make_the_patches_from_any_points():
    """A skinned cage's control points are weighted sums of its points (CSR stencils):
    applied to moved points they give the patches of the moved cage, creases included."""
    from lantern.engine.bezier_patches import patch_stencils

    base = cage(CUBE_POINTS, [4] * 6, np.ravel(CUBE_FACES), crease_pairs=[(0, 1)],
                crease_sharpness=[2.5])
    rows, points, weights = patch_stencils(base, 3, block=3)      # blocks of 3 columns
    moved = CUBE_POINTS * [1.0, 2.0, 0.5] + np.random.default_rng(1).normal(0, 0.1, (8, 3))
    made = np.add.reduceat(weights[:, None] * moved[points], rows[:-1])
    expected = bezier_patches(refine(cage(moved, base.counts, base.indices, [(0, 1)], [2.5]), 3))
    assert np.abs(made - expected.reshape(-1, 3)).max() < 1e-12
    assert (weights > 0).all() and np.allclose(np.add.reduceat(weights, rows[:-1]), 1.0)
