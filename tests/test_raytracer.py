"""The ray tracer (engine/bvh.py, engine/gpu/raytracer.py, shaders/raytrace.glsl): its
hits against brute force, on the crowd and the demo; refitting against building;
instances sharing their prototype's tree; and the triangle test's edge cases."""
import numpy as np
import pytest

import raytrace_reference
import skel_scenes
from lantern.engine import RenderSettings, Session
from lantern.engine.gpu.raytracer import patch_triangles

RAYS = 100_000
SETTINGS = RenderSettings(width=16, height=16, preset="low")


def random_rays(lo, hi, n=RAYS, seed=1):
    """Origins uniform in the box (lo, hi), directions uniform on the sphere."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    return rng.uniform(lo, hi, (n, 3)), d / np.linalg.norm(d, axis=1, keepdims=True)


def world_triangles(session, instances, frame):
    """(T, 3, 3) float64 world triangles of the tracer's instances in its order, each
    instance's first triangle among them, and each triangle's material: from the
    scene's records (skinned meshes from the skinning pass's points, read back:
    Session.skinned_points)."""
    scene = session.scene
    skinned = session.skinned_points(frame)
    out, first, materials = [], [], []
    for path, k in instances:
        inst = scene.instances[path]
        mesh = scene.meshes[inst.mesh_key]
        first.append(sum(len(t) for t in out))
        per, ranges = (2, mesh.patches.ranges) if mesh.patches is not None else (1, [
            (m, f // 3, c // 3) for m, f, c in mesh.ranges])
        named = np.empty(sum(c for _, _, c in ranges) * per, object)
        for m, f, c in ranges:
            named[f * per:(f + c) * per] = mesh.materials[m]
        materials.append(named)
        if mesh.patches is not None and mesh.skin is not None:     # a skinned cage
            out.append(patch_triangles(mesh.patches, skinned[path][0]).astype(np.float64))
            continue
        if mesh.patches is not None:
            local = patch_triangles(mesh.patches).astype(np.float64)
        elif mesh.skin is not None:
            points = skinned[path][0]
            out.append(points[mesh.point_of_vertex[mesh.indices.reshape(-1, 3)]])
            continue
        else:
            local = mesh.vertices[:, :3].astype(np.float64)[mesh.indices.reshape(-1, 3)]
        world = inst.world if inst.worlds is None else inst.worlds[k]
        out.append(local @ world[:3, :3].T + world[:3, 3])
    return np.concatenate(out), np.array(first), np.concatenate(materials)


def assert_matches_reference(hits, triangles, first, origins, directions, what, hit_share=0.2):
    """Every ray's hit against the float64 reference: the same triangle at the same
    distance (within float32's rounding of the scene's coordinates), or, only where the
    reference's hit lies within 1e-5 of an edge or a second triangle at the same
    distance, a hit as near on the triangle found, or a miss at an edge."""
    t_ref, tri_ref, margin, second = raytrace_reference.closest_hits(triangles, origins, directions)
    tol = 1e-5 * (1.0 + np.abs(t_ref))
    tri = np.where(hits.instance >= 0, first[np.maximum(hits.instance, 0)] + hits.local, -1)
    hit, ref_hit = hits.t >= 0, t_ref >= 0
    same = (hit == ref_hit) & (tri == tri_ref) & (~hit | (np.abs(hits.t - t_ref) <= tol))
    close_call = ref_hit & ((margin < 1e-5) | (second - t_ref <= tol))
    # A hit that is not the reference's lies on its own triangle, as near as the reference's.
    other = np.nonzero(~same & hit)[0]
    t64, u, v = raytrace_reference.moller_trumbore(
        triangles[tri[other]], origins[other].astype(np.float64), directions[other])
    on_it = np.abs(t64 - hits.t[other]) <= tol[other] * 10
    as_near = ~ref_hit[other] | (hits.t[other] <= t_ref[other] + tol[other])
    grazing = np.minimum(np.minimum(u, v), 1 - u - v) > -1e-5
    wrong = np.zeros(len(same), bool)
    wrong[other] = ~(on_it & as_near & (close_call[other] | (~ref_hit[other] & grazing)))
    missed = ~same & ~hit & ~close_call
    bad = np.nonzero(wrong | missed)[0]
    assert not len(bad), (
        f"{what}: {len(bad)} of {len(same)} rays differ from the reference; first: ray "
        f"{bad[0]} hit {tri[bad[0]]} at {hits.t[bad[0]]}, reference {tri_ref[bad[0]]} at "
        f"{t_ref[bad[0]]}")
    assert np.count_nonzero(~same) <= len(same) * 1e-3, f"{what}: {np.count_nonzero(~same)} close calls"
    assert ref_hit.mean() > hit_share, f"{what}: too few rays hit ({ref_hit.mean():.2f})"
    return np.count_nonzero(~same)


def assert_same_hits(a, b, what):
    same = (a.t == b.t) & (a.instance == b.instance) & (a.triangle == b.triangle)
    bad = np.nonzero(~same)[0]
    assert not len(bad), (f"{what}: {len(bad)} of {len(same)} rays differ; first: ray {bad[0]} "
                          f"({a.instance[bad[0]]}, {a.triangle[bad[0]]}, {a.t[bad[0]]}) against "
                          f"({b.instance[bad[0]]}, {b.triangle[bad[0]]}, {b.t[bad[0]]})")


# --- against brute force -----------------------------------------------------------------

def test_the_crowd_hits_as_brute_force():
    """100,000 random rays on the crowd (two skinned meshes and a floor): the trees'
    hits are the brute-force shader's exactly (every triangle of every instance, the
    same test, no tree), and the float64 reference's; any-hit finds a hit on every ray
    that has one."""
    origins, directions = random_rays((-6, -6, -2), (10, 6, 3))
    with Session(skel_scenes.crowd_stage(), SETTINGS) as session:
        hits, instances, counts = session.trace(origins, directions, frame=2.0)
        brute, _, _ = session.trace(origins, directions, frame=2.0, brute_force=True)
        anyhit, _, _ = session.trace(origins, directions, frame=2.0, any_hit=True)
        triangles, first, materials = world_triangles(session, instances, 2.0)
    assert counts["bottom_builds"] == 3 and counts["triangles"] == len(triangles) == 74
    assert_same_hits(hits, brute, "crowd, trees against brute force")
    assert np.array_equal(anyhit.t >= 0, hits.t >= 0)
    assert_matches_reference(hits, triangles, first, origins, directions, "crowd")


def test_the_demo_hits_as_brute_force():
    """100,000 random rays on the demo at frame 13 (a subdivided Suzanne's patches, a
    skinned tentacle, a sphere, a box, the ground: 19,000 triangles) against the float64
    brute-force reference."""
    import test_looks
    origins, directions = random_rays((-6, -6, -1), (6, 6, 4))
    with Session(test_looks.stage_of("demo"), SETTINGS) as session:
        hits, instances, counts = session.trace(origins, directions, frame=13.0)
        triangles, first, materials = world_triangles(session, instances, 13.0)
    assert counts["triangles"] == len(triangles) > 15_000
    assert_matches_reference(hits, triangles, first, origins, directions, "demo")
    hit = np.nonzero(hits.t >= 0)[0]
    expected = materials[first[hits.instance[hit]] + hits.local[hit]]
    assert [hits.material[i] for i in hit] == list(expected)
    assert {m.rsplit("/", 1)[-1] for m in expected} >= {"Clay", "Gold", "Checker", "Bumpy"}


# --- keeping up with the scene -------------------------------------------------------------

def test_a_refit_after_the_rig_moves_hits_as_a_fresh_build():
    """The crowd traced at frame 1, then at frame 3 (the skinned meshes refitted, not
    built again) hits exactly what a session that builds its trees at frame 3 hits;
    the rig moved, so frame 1's hits differ."""
    origins, directions = random_rays((-6, -6, -2), (10, 6, 3), n=20_000, seed=2)
    stage = skel_scenes.crowd_stage()
    with Session(stage, SETTINGS) as session:
        before, _, _ = session.trace(origins, directions, frame=1.0)
        refitted, _, counts = session.trace(origins, directions, frame=3.0)
    assert counts["bottom_builds"] == 3 and counts["refits"] >= 2
    with Session(stage, SETTINGS) as session:
        built, _, fresh = session.trace(origins, directions, frame=3.0)
    assert fresh["bottom_builds"] == 3 and not fresh.get("refits")
    assert_same_hits(refitted, built, "refitted against built")
    assert np.count_nonzero(before.t != refitted.t) > 100


def test_a_time_sampled_mesh_is_refitted():
    """A mesh whose points are sampled in time, traced at frame 1 then 4, is refitted
    and hits what a fresh build at frame 4 hits."""
    import session_scenes
    stage = session_scenes.time_sampled_mesh_stage(frames=5, grid=40)
    origins, directions = random_rays((-2, -2, 0), (2, 2, 1.5), n=20_000, seed=5)
    with Session(stage, SETTINGS) as session:
        before, _, _ = session.trace(origins, directions, frame=1.0)
        refitted, _, counts = session.trace(origins, directions, frame=4.0)
    with Session(stage, SETTINGS) as session:
        built, _, fresh = session.trace(origins, directions, frame=4.0)
    assert counts["refits"] == 1 and counts["bottom_builds"] == fresh["bottom_builds"]
    assert_same_hits(refitted, built, "time-sampled mesh, refitted against built")
    assert np.count_nonzero(before.t != refitted.t) > 100


def test_a_skinned_subdivision_surface_is_traced_as_posed():
    """A skinned cage subdivided on the GPU: its patches' corners follow the rig (the
    cage's posed points through the patches' stencils), refitted at a new frame, as the
    float64 reference places them."""
    from pxr import Sdf, UsdGeom
    stage = skel_scenes.skel_stage(3, grid=6)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/root/mesh"))
    mesh.CreateSubdivisionSchemeAttr("catmullClark")
    mesh.GetPrim().CreateAttribute("lantern:subdivisionRenderLevel", Sdf.ValueTypeNames.Int).Set(2)
    origins, directions = random_rays((-1, -1.5, -1.5), (5, 1.5, 1.5), n=20_000, seed=6)
    with Session(stage, SETTINGS) as session:
        before, _, _ = session.trace(origins, directions, frame=1.0)
        hits, instances, counts = session.trace(origins, directions, frame=3.0)
        triangles, first, _ = world_triangles(session, instances, 3.0)
        assert session.scene.meshes[("skinned", "/root/mesh")].patches.stencils is not None
    assert counts["refits"] == 1 and counts["triangles"] == len(triangles) > 100
    assert np.count_nonzero(before.t != hits.t) > 100
    assert_matches_reference(hits, triangles, first, origins, directions, "skinned cage",
                             hit_share=0.05)                 # a narrow strip


def _stage():
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    return stage


def _mesh(stage, path, points, faces):
    from pxr import UsdGeom
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([tuple(map(float, p)) for p in points])
    mesh.CreateFaceVertexCountsAttr([len(f) for f in faces])
    mesh.CreateFaceVertexIndicesAttr([int(i) for f in faces for i in f])
    mesh.CreateSubdivisionSchemeAttr("none")    # a polygon mesh (unauthored: catmullClark)
    return mesh


CUBE_POINTS = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
CUBE_FACES = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]


def test_instances_share_their_prototypes_tree():
    """A PointInstancer's 40 rotated and scaled cubes are one bottom-level tree under
    40 top-level leaves, and each is hit where the reference places it."""
    from pxr import Gf, UsdGeom
    stage = _stage()
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    _mesh(stage, "/PI/Protos/Cube", CUBE_POINTS, CUBE_FACES)
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Cube"])
    rng = np.random.default_rng(3)
    pi.CreateProtoIndicesAttr([0] * 40)
    pi.CreatePositionsAttr([Gf.Vec3f(*map(float, p)) for p in rng.uniform(-8, 8, (40, 3))])
    q = rng.normal(size=(40, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    pi.CreateOrientationsAttr([Gf.Quath(*map(float, r)) for r in q])
    pi.CreateScalesAttr([Gf.Vec3f(*map(float, s)) for s in rng.uniform(0.3, 1.5, (40, 3))])
    origins, directions = random_rays((-9, -9, -9), (9, 9, 9), n=20_000, seed=4)
    with Session(stage, SETTINGS) as session:
        hits, instances, counts = session.trace(origins, directions)
        triangles, first, materials = world_triangles(session, instances, 1.0)
    assert counts["bottom_builds"] == 1 and counts["triangles"] == 12
    assert len(instances) == 40 and len(set(hits.instance[hits.instance >= 0])) == 40
    assert_matches_reference(hits, triangles, first, origins, directions, "instances")
    # What a shader reads at a hit: the object table's id (an instance's, consecutive
    # in the batch) and the world normal of the triangle's winding.
    hit = hits.instance >= 0
    k = np.array([instances[i][1] for i in hits.instance[hit]])
    assert len(set(hits.object[hit] - k)) == 1
    tri = triangles[first[hits.instance[hit]] + hits.local[hit]]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.abs(hits.normal[hit] - normal).max() < 1e-4


def test_nothing_is_built_until_rays_are_asked_for():
    with Session(skel_scenes.crowd_stage(), SETTINGS) as session:
        result = session.render(frame=2.0)
        assert not result.stats["bytes_by_kind"].get("raytrace")
        session.trace([(0, 0, 5)], [(0, 0, -1)], frame=2.0)
        assert session.render(frame=3.0).stats["bytes_by_kind"].get("raytrace", 0) == 0


def test_without_compute_shaders_tracing_says_why(monkeypatch):
    monkeypatch.setenv("LANTERN_MAX_GL", "41")
    with Session(skel_scenes.crowd_stage(), SETTINGS) as session:
        with pytest.raises(ValueError, match=r"ray tracing needs compute shaders \(GL 4.3\); "
                                             r"this context is GL 4.1"):
            session.trace([(0, 0, 5)], [(0, 0, -1)])


# --- the triangle test ---------------------------------------------------------------------

def _trace(stage, origins, directions, **options):
    with Session(stage, SETTINGS) as session:
        closest, _, counts = session.trace(origins, directions, **options)
        anyhit, _, _ = session.trace(origins, directions, any_hit=True, **options)
    return closest, anyhit, counts


def test_rays_through_shared_edges_and_vertices_do_not_fall_through():
    """A closed cube and a closed sphere (a UV sphere's 2,208 triangles), each seen from
    inside: rays exactly through every vertex and (on the cube, whose coordinates are
    exact) every edge's midpoint and quarter points, and rays through every sphere
    vertex from outside, all hit; none falls through a seam."""
    from pxr import UsdGeom
    stage = _stage()
    _mesh(stage, "/Cube", CUBE_POINTS, CUBE_FACES)
    points = np.array(CUBE_POINTS, float)
    edges = [(a, b) for f in CUBE_FACES for a, b in zip(f, f[1:] + f[:1]) if a < b]
    targets = [points] + [points[a] + s * (points[b] - points[a])
                          for a, b in edges for s in (0.25, 0.5, 0.75)]
    targets = np.vstack([np.atleast_2d(t) for t in targets])
    inside = np.array([(0, 0, 0), (0.5, 0.25, -0.25), (-0.5, 0.5, 0.75)])
    origins = np.repeat(inside, len(targets), 0)
    directions = np.tile(targets, (len(inside), 1)) - origins
    closest, anyhit, _ = _trace(stage, origins, directions)
    assert (closest.t > 0).all() and (anyhit.t > 0).all(), \
        f"{np.count_nonzero(closest.t <= 0)} rays through the cube's seams fell through"
    assert np.allclose(closest.t[:len(targets)], 1.0, rtol=1e-6)

    stage = _stage()
    UsdGeom.Sphere.Define(stage, "/Ball").CreateRadiusAttr(2.0)
    with Session(stage, SETTINGS) as session:
        session.trace([(0, 0, 0)], [(0, 0, 1)])
        mesh = next(iter(session.scene.meshes.values()))
        vertices = np.unique(mesh.vertices[:, :3].astype(np.float64), axis=0)
        origins = np.vstack([np.zeros((len(vertices), 3)), vertices * 3.0])
        directions = np.vstack([vertices, -vertices * 2.0])
        hits, _, counts = session.trace(origins, directions)
    assert counts["triangles"] > 2000
    assert (hits.t > 0).all(), f"{np.count_nonzero(hits.t <= 0)} rays through the sphere's vertices fell through"


def test_degenerate_triangles_and_rays_along_a_face():
    """Triangles of no area (three points on a line, a repeated point) are never hit
    and hide nothing behind them; a ray in a face's plane misses it and goes on; rays
    along an axis (zero components) hit where the plane is."""
    stage = _stage()
    _mesh(stage, "/Sliver", [(-1, 0, 1), (0, 0, 1), (1, 0, 1), (0, 1, 1)], [(0, 1, 2), (1, 3, 3)])
    _mesh(stage, "/Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], [(0, 1, 2, 3)])
    _mesh(stage, "/Wall", [(5, -4, -1), (5, 4, -1), (5, 4, 1), (5, -4, 1)], [(0, 1, 2, 3)])
    origins = np.array([(0.0, 0.0, 3.0), (0.5, 0.0, 3.0), (0.0, 0.5, 3.0),   # onto the slivers
                        (0.0, 0.0, 0.0), (-2.0, 1.0, 0.0),                     # in the floor's plane
                        (1.0, 1.0, 2.0), (-3.0, 2.0, -2.0)])                   # along z
    directions = np.array([(0, 0, -1), (0, 0, -1), (0, 0, -1), (1, 0, 0), (1, 0, 0),
                           (0, 0, -1), (0, 0, 1)], float)
    closest, anyhit, counts = _trace(stage, origins, directions)
    assert counts["triangles"] == 6
    assert np.allclose(closest.t, [3, 3, 3, 5, 7, 2, 2]), closest.t
    assert np.isfinite(closest.barycentric).all() and (anyhit.t > 0).all()


def test_an_instance_of_zero_scale_is_left_out_with_a_warning():
    from pxr import Gf, UsdGeom
    stage = _stage()
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    _mesh(stage, "/PI/Protos/Cube", CUBE_POINTS, CUBE_FACES)
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Cube"])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(3, 0, 0), Gf.Vec3f(6, 0, 0)])
    pi.CreateScalesAttr([Gf.Vec3f(1, 1, 1), Gf.Vec3f(0, 1, 1), Gf.Vec3f(1, 1, 1)])
    with Session(stage, SETTINGS) as session:
        hits, instances, _ = session.trace([(-5, 0, 0)] * 2, [(1, 0, 0), (-1, 0, 0)])
        warnings = session.render().warnings
    assert [k for _, k in instances] == [0, 2]
    assert hits.t[0] == pytest.approx(4.0) and hits.t[1] < 0
    assert any("1 instance(s) of zero scale not ray traced" in w for w in warnings), warnings
