"""Instancing in the engine: PointInstancers drawn with GPU instancing (one command per
prototype mesh, however many instances), instanceable references sharing their GPU
geometry, and Points prims as spheres expanded on the GPU.

- A PointInstancer (two prototypes under a class prim, orientations, scales, a
  mirroring instance, an invisible and an inactive id) renders like the same meshes
  authored one by one (max abs <= 1e-5); its prototypes are not drawn on their own.
- 4,096 instances are one draw command; 100 instanceable references upload one mesh.
- A Points prim's spheres match a finely meshed sphere: coverage differs only on the
  silhouette (the mesh's facets), and the lit pixels agree on average.
- A particle scene shows its particles, lit and casting shadows."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from lantern.engine import RenderSettings, Session, render_stage

from hard_cases import engine_scenes as E  # tests/ is on sys.path (conftest.py)
S = E.S
W, H = 160, 90


def _render(stage, w=W, h=H):
    result = render_stage(stage, RenderSettings(width=w, height=h))
    assert np.isfinite(result.rgba).all()
    return result


def _base():
    stage = S.new_stage(half=6.0)
    S.add_light(stage, "sun", strength=2.0, dir=(0.4, 0.5, -1.0), angle=1.0)
    S.add_light(stage, "point", pos=(-1.0, -2.0, 3.0), power=200.0, radius=0.1)
    S.add_camera(stage, eye=(6.0, -8.0, 5.0), target=(0.0, 0.0, 0.5))
    return stage


INSTANCES = [  # prototype, position, rotation (deg about z, x), scale
    (0, (-2.0, -1.0, 0.3), (0, 0), (1, 1, 1)),
    (0, (0.0, -1.5, 0.3), (30, 0), (1.5, 1, 1)),
    (1, (2.0, -1.0, 0.5), (10, 20), (1, 1, 1)),
    (1, (-2.0, 1.5, 0.5), (0, 0), (-1, 1, 1)),     # mirroring
    (0, (0.5, 1.5, 0.3), (45, 10), (1, 1, 2)),
    (0, (2.5, 2.0, 0.3), (0, 0), (1, 1, 1)),       # invisible id
    (1, (1.0, 0.0, 0.5), (0, 0), (1, 1, 1)),       # inactive id
]


def _quat(z_deg, x_deg):
    r = Gf.Rotation(Gf.Vec3d(0, 0, 1), z_deg) * Gf.Rotation(Gf.Vec3d(1, 0, 0), x_deg)
    q = r.GetQuat()
    return Gf.Quatf(q.GetReal(), Gf.Vec3f(q.GetImaginary()))


def _prototypes(stage):
    UsdGeom.Scope.Define(stage, "/root/_protos").GetPrim().SetSpecifier(Sdf.SpecifierClass)
    S.add_box(stage, (0, 0, 0), 0.6, "_protos/box")
    proto = UsdGeom.Xform.Define(stage, "/root/_protos/pair")
    proto.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.1))          # the prototype root's own xform
    S.add_box(stage, (0, 0, 0), 0.4, "_protos/pair/a")
    S.add_box(stage, (0.3, 0, 0.2), 0.3, "_protos/pair/b")
    return ["/root/_protos/box", "/root/_protos/pair"]


def _instanced():
    stage = _base()
    protos = _prototypes(stage)
    pi = UsdGeom.PointInstancer.Define(stage, "/root/scatter")
    pi.AddTranslateOp().Set(Gf.Vec3d(0.2, 0.1, 0.0))
    pi.CreatePrototypesRel().SetTargets(protos)
    pi.CreateProtoIndicesAttr([i[0] for i in INSTANCES])
    pi.CreatePositionsAttr([Gf.Vec3f(*i[1]) for i in INSTANCES])
    pi.CreateOrientationsAttr([Gf.Quath(_quat(*i[2])) for i in INSTANCES])
    pi.CreateScalesAttr([Gf.Vec3f(*i[3]) for i in INSTANCES])
    pi.CreateInvisibleIdsAttr([5])
    pi.DeactivateId(6)
    return stage


def _authored_one_by_one():
    """The same instances as plain prims: each an Xform (instancer, translate, orient,
    scale) holding its own copy of the prototype's meshes."""
    stage = _base()
    for k, (proto, pos, rot, scale) in enumerate(INSTANCES[:5]):
        xf = UsdGeom.Xform.Define(stage, f"/root/i{k}")
        xf.AddTranslateOp().Set(Gf.Vec3d(0.2, 0.1, 0.0))
        xf.AddTranslateOp(opSuffix="pos").Set(Gf.Vec3d(*pos))
        xf.AddOrientOp().Set(Gf.Quatf(Gf.Quath(_quat(*rot))))
        xf.AddScaleOp().Set(Gf.Vec3f(*scale))
        if proto == 0:
            S.add_box(stage, (0, 0, 0), 0.6, f"i{k}/box")
        else:
            inner = UsdGeom.Xform.Define(stage, f"/root/i{k}/pair")
            inner.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.1))
            S.add_box(stage, (0, 0, 0), 0.4, f"i{k}/pair/a")
            S.add_box(stage, (0.3, 0, 0.2), 0.3, f"i{k}/pair/b")
    return stage


def test_a_point_instancer_renders_like_its_instances_authored_one_by_one(hard_case):
    a = _render(_instanced())
    b = _render(_authored_one_by_one())
    assert not a.warnings
    # Boxes: 3 instances; pair meshes a and b: 2 instances each (one mirroring, a
    # batch of its own): 7 instances in 5 commands, against 7 separate draws.
    assert a.stats["instances_drawn"] == 7
    assert a.stats["draw_calls"] == 1 + 5 and b.stats["draw_calls"] == 1 + 7
    # The same matrices composed in another order differ in their last bits, and the
    # point light's soft-shadow blocker search turns those into small steps inside its
    # penumbra (97 pixels above 1e-4, one above 1e-3); everywhere else they agree.
    diff = np.abs(a.rgba - b.rgba)[..., :3].max(axis=-1)
    hard_case("PointInstancer (2 prototypes, orientations, scales, a mirroring instance, "
              "invisible and inactive ids) vs the same meshes one by one, max abs",
              float(diff.max()), 5e-3)
    hard_case("PointInstancer vs one by one: pixels differing by > 1e-3",
              int((diff > 1e-3).sum()), 5, "px")


def test_with_the_bounce_a_point_instancer_still_renders_like_its_instances(hard_case):
    # A frame that bounces light also traces contact rays from every receiver towards
    # the sun (docs/rendering.md, "Shadow seams"): decisions on the triangles, which
    # must not flip with the matrices' last bits as the map's did. Held on the direct
    # light's render passes, where they act; the field's wall test by planes flips on
    # those bits too (29 pixels over 1e-3 in the whole image, all under 5e-3:
    # docs/status.md). Without FXAA: its edge search turns such a difference on a
    # pixel beside an edge into a step of the edge (0.056 at one pixel).
    from lantern.engine.bounces import Bounces
    settings = RenderSettings(width=W, height=H, bounces=Bounces(), fxaa=False,
                              passes=frozenset({"DiffDir", "GlossDir"}))
    a = render_stage(_instanced(), settings)
    b = render_stage(_authored_one_by_one(), settings)
    assert a.stats["field_updates"] == 4
    direct = [r.passes["DiffDir"][..., :3] + r.passes["GlossDir"][..., :3] for r in (a, b)]
    diff = np.abs(direct[0] - direct[1]).max(axis=-1)
    hard_case("PointInstancer vs one by one, with the bounce (contact rays), direct light, "
              "max abs", float(diff.max()), 5e-3)
    hard_case("PointInstancer vs one by one, with the bounce: direct light's pixels "
              "differing by > 1e-3", int((diff > 1e-3).sum()), 5, "px")
    whole = np.abs(a.rgba - b.rgba)[..., :3].max(axis=-1)
    hard_case("PointInstancer vs one by one, with the bounce, whole image, max abs",
              float(whole.max()), 5e-3)


def test_prototypes_under_a_class_prim_are_not_drawn_on_their_own():
    stage = _instanced()
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/root/scatter"))
    pi.CreateProtoIndicesAttr([])
    pi.CreatePositionsAttr([])
    empty = _render(stage)
    base = _render(_base())
    assert np.abs(empty.rgba - base.rgba).max() == 0.0


def test_many_instances_are_one_command_each(hard_case):
    stage = _base()
    protos = _prototypes(stage)
    n = 64
    g = (np.arange(n) - n / 2) * 0.09
    pos = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    pi = UsdGeom.PointInstancer.Define(stage, "/root/crowd")
    pi.CreatePrototypesRel().SetTargets(protos[:1])
    pi.CreateProtoIndicesAttr(Vt.IntArray([0] * len(pos)))
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(
        np.c_[pos, np.full(len(pos), 0.05)].astype(np.float32)))
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(np.full((len(pos), 3), 0.1, np.float32)))
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        first = session.render()
        again = session.render()
    assert first.stats["instances_drawn"] == n * n
    assert first.stats["draw_calls"] == 2                  # the floor and the crowd
    assert again.stats["bytes_uploaded"] <= 16 * 1024      # the view did not change
    hard_case.record(f"{n * n} instances of one prototype: render time (warm)",
                     again.timings["total"] * 1e3, "ms")


def test_instanceable_references_share_their_gpu_geometry():
    stage = _base()
    asset = Usd.Stage.CreateInMemory()
    UsdGeom.Xform.Define(asset, "/asset")
    S.white_material(asset)
    S.add_box(asset, (0, 0, 0.2), 0.4, "box")
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layer.TransferContent(asset.GetRootLayer())
    for k in range(100):
        prim = stage.DefinePrim(f"/root/ref{k}", "Xform")
        prim.GetReferences().AddReference(layer.identifier, "/root")
        prim.SetInstanceable(True)
        UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(k % 10 - 4.5, k // 10 - 4.5, 0))
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        result = session.render()
    assert result.stats["meshes_uploaded"] == 2            # the floor and the one box
    assert result.stats["draw_calls"] >= 100


def _sphere_mesh(stage, path, center, radius, n=96):
    """A UV sphere with smooth normals, n segments around."""
    u = np.linspace(0, 2 * np.pi, n, endpoint=False)
    v = np.linspace(0, np.pi, n // 2 + 1)[1:-1]
    ring = np.stack([np.outer(np.sin(v), np.cos(u)), np.outer(np.sin(v), np.sin(u)),
                     np.repeat(np.cos(v)[:, None], n, 1)], -1).reshape(-1, 3)
    pts = np.vstack([[0, 0, 1], ring, [0, 0, -1]])
    faces, counts = [], []
    rows = len(v)
    for j in range(n):
        faces += [0, 1 + j, 1 + (j + 1) % n]
        counts.append(3)
    for i in range(rows - 1):
        for j in range(n):
            a, b = 1 + i * n + j, 1 + i * n + (j + 1) % n
            faces += [a, a + n, b + n, b]
            counts.append(4)
    last = 1 + rows * n
    for j in range(n):
        faces += [last, 1 + (rows - 1) * n + (j + 1) % n, 1 + (rows - 1) * n + j]
        counts.append(3)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy((pts * radius + center).astype(np.float32)))
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateFaceVertexCountsAttr(counts)
    mesh.CreateFaceVertexIndicesAttr(faces)
    return mesh


SPHERES = [((-1.0, 0.0, 0.6), 0.6), ((0.8, -0.5, 0.4), 0.4), ((0.3, 1.2, 0.9), 0.5)]


def _spheres(as_points):
    stage = _base()
    if as_points:
        p = UsdGeom.Points.Define(stage, "/root/cloud")
        p.CreatePointsAttr([Gf.Vec3f(*c) for c, _ in SPHERES])
        p.CreateWidthsAttr([2 * r for _, r in SPHERES])
        p.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.8, 0.5, 0.3)])
    else:
        for k, (c, r) in enumerate(SPHERES):
            m = _sphere_mesh(stage, f"/root/s{k}", np.asarray(c), r)
            m.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.8, 0.5, 0.3)])
    return stage


@pytest.mark.parametrize("gl", ["45", "33"])
def test_points_are_spheres(gl, hard_case, monkeypatch):
    monkeypatch.setenv("LANTERN_MAX_GL", gl)
    pts = _render(_spheres(True), 320, 180)
    mesh = _render(_spheres(False), 320, 180)
    assert not pts.warnings and pts.stats["points_drawn"] == 3
    diff = np.abs(pts.rgba - mesh.rgba)[..., :3].max(-1)
    # The meshed sphere's facets move its silhouette by up to r (1 - cos(pi / 96))
    # and tilt its normals: edge pixels differ, the rest agree closely.
    hard_case(f"Points spheres vs 96-segment meshed spheres (GL {gl[0]}.{gl[1]}): pixels "
              f"differing by > 0.05", int((diff > 0.05).sum()), 10, "px")
    # 3e-5: the spheres' G-buffer once carried a full clearcoat of roughness 1 that
    # the meshes' material does not have (6.7e-5).
    hard_case(f"Points spheres vs meshed spheres (GL {gl[0]}.{gl[1]}): mean abs difference",
              float(diff.mean()), 3e-5)


def test_a_particle_scene_shows_its_particles_lit_and_shadowed(hard_case):
    rng = np.random.default_rng(7)
    stage = _base()
    n = 500
    pts = rng.uniform([-2, -2, 0.5], [2, 2, 2.0], (n, 3))
    p = UsdGeom.Points.Define(stage, "/root/particles")
    p.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    p.CreateWidthsAttr(Vt.FloatArray([0.12] * n))
    with_particles = _render(stage)
    floor_only = _render(_base())
    assert with_particles.stats["points_drawn"] == n
    changed = np.abs(with_particles.rgba - floor_only.rgba)[..., :3].max(-1) > 0.02
    # Particles in view, and their shadows on the floor (pixels darker than without).
    darker = (with_particles.rgba[..., :3].sum(-1) < floor_only.rgba[..., :3].sum(-1) - 0.05)
    hard_case("500 particles (Points, 0.12 wide) at 160x90: pixels they change",
              int(changed.sum()), 200, "px", lower=True)
    hard_case("500 particles: pixels darker than the bare floor (shadows)",
              int(darker.sum()), 50, "px", lower=True)


def test_instancer_and_points_edits_and_frames_equal_fresh_renders():
    """A Session picks up edits to an instancer, a prototype and a Points prim, and
    time-sampled positions at a new frame, as a fresh render of the stage shows them."""
    stage = _instanced()
    cloud = UsdGeom.Points.Define(stage, "/root/cloud")
    cloud.CreatePointsAttr([Gf.Vec3f(0, 0, 1.5), Gf.Vec3f(1, 0, 1.8)])
    cloud.CreateWidthsAttr([0.3, 0.4])
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/root/scatter"))
    settings = RenderSettings(width=W, height=H)

    def fresh(frame=None):
        return render_stage(stage, RenderSettings(width=W, height=H, frame=frame)).rgba

    with Session(stage, settings) as session:
        session.render()
        positions = [Gf.Vec3f(p[0] + 0.3, p[1], p[2]) for p in pi.GetPositionsAttr().Get()]
        pi.GetPositionsAttr().Set(positions)
        moved = session.render()
        assert moved.stats["meshes_uploaded"] == 0
        assert np.abs(moved.rgba - fresh()).max() == 0.0
        UsdGeom.Xformable(stage.GetPrimAtPath("/root/_protos/pair")).GetOrderedXformOps()[0].Set(
            Gf.Vec3d(0, 0, 0.4))                                   # a prototype edit
        assert np.abs(session.render().rgba - fresh()).max() == 0.0
        cloud.GetPointsAttr().Set([Gf.Vec3f(-1, 0, 1.5)])
        cloud.GetWidthsAttr().Set([0.6])
        assert np.abs(session.render().rgba - fresh()).max() == 0.0
        attr = pi.GetPositionsAttr()
        base = attr.Get()
        attr.Clear()
        for f in (1.0, 2.0):
            attr.Set([Gf.Vec3f(p[0], p[1] + 0.5 * f, p[2]) for p in base], f)
        for f in (1.0, 2.0):
            assert np.abs(session.render(frame=f).rgba - fresh(f)).max() == 0.0
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/root/_protos/box"))
        mesh.GetPointsAttr().Set([Gf.Vec3f(p) * 1.5 for p in mesh.GetPointsAttr().Get()])
        edited = session.render(frame=2.0)                     # prototype geometry edited
        assert edited.stats["meshes_uploaded"] >= 1
        assert np.abs(edited.rgba - fresh(2.0)).max() == 0.0


OUTER = [((-2.0, -1.0, 0.0), (0, 0), (1, 1, 1)),          # position, rotation, scale
         ((1.5, 1.0, 0.2), (40, 0), (1, 1, 1)),
         ((1.0, -2.0, 0.0), (0, 15), (1.5, 1.5, 1.5))]
INNER = [(0.0, 0.0, 0.0), (0.6, 0.0, 0.0), (1.2, 0.0, 0.3), (1.8, 0.0, 0.0)]


def _nested():
    """A PointInstancer whose prototype (an Xform with a box of its own) holds another
    PointInstancer, turned and lifted, whose prototype (under it) is a smaller box:
    3 outer instances x 3 inner ones (one of 4 invisible), and the 3 outer boxes."""
    stage = _base()
    UsdGeom.Scope.Define(stage, "/root/_protos").GetPrim().SetSpecifier(Sdf.SpecifierClass)
    row = UsdGeom.Xform.Define(stage, "/root/_protos/row")
    row.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.3))
    S.add_box(stage, (0, 0, 0), 0.5, "_protos/row/base")
    inner = UsdGeom.PointInstancer.Define(stage, "/root/_protos/row/inner")
    inner.AddTranslateOp().Set(Gf.Vec3d(0, 0.2, 0.5))
    inner.AddRotateZOp().Set(30.0)
    S.add_box(stage, (0, 0, 0), 0.25, "_protos/row/inner/protos/cube")
    inner.CreatePrototypesRel().SetTargets(["/root/_protos/row/inner/protos/cube"])
    inner.CreateProtoIndicesAttr([0] * len(INNER))
    inner.CreatePositionsAttr([Gf.Vec3f(*p) for p in INNER])
    inner.CreateInvisibleIdsAttr([2])
    outer = UsdGeom.PointInstancer.Define(stage, "/root/rows")
    outer.AddTranslateOp().Set(Gf.Vec3d(0.2, 0.1, 0.0))
    outer.CreatePrototypesRel().SetTargets(["/root/_protos/row"])
    outer.CreateProtoIndicesAttr([0] * len(OUTER))
    outer.CreatePositionsAttr([Gf.Vec3f(*o[0]) for o in OUTER])
    outer.CreateOrientationsfAttr([_quat(*o[1]) for o in OUTER])   # unit to float precision
    outer.CreateScalesAttr([Gf.Vec3f(*o[2]) for o in OUTER])
    return stage


def _expected_worlds(stage):
    """{mesh: [world, row-vector]} by USD's own instance transforms, composed: mesh in
    its prototype . inner instance . inner instancer in the row . outer instance .
    outer instancer's world."""
    t = Usd.TimeCode.Default()
    outer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/root/rows"))
    inner = UsdGeom.PointInstancer(stage.GetPrimAtPath("/root/_protos/row/inner"))
    world = UsdGeom.XformCache(t).GetLocalToWorldTransform(outer.GetPrim())
    inner_local = UsdGeom.Xformable(inner).GetLocalTransformation(t)
    outers = [m * world for m in outer.ComputeInstanceTransformsAtTime(t, t)]
    inners = inner.ComputeInstanceTransformsAtTime(t, t)      # the invisible id left out
    assert len(inners) == len(INNER) - 1
    return {"/root/_protos/row/base": outers,
            "/root/_protos/row/inner/protos/cube": [j * inner_local * o for o in outers
                                                    for j in inners]}


def _one_by_one(worlds):
    stage = _base()
    for k, (mesh, matrices) in enumerate(sorted(worlds.items())):
        size = 0.5 if mesh.endswith("base") else 0.25
        for i, m in enumerate(matrices):
            UsdGeom.Xform.Define(stage, f"/root/m{k}_{i}").AddTransformOp().Set(m)
            S.add_box(stage, (0, 0, 0), size, f"m{k}_{i}/box")
    return stage


def test_a_point_instancer_inside_a_prototype_draws_its_instances_there(hard_case):
    """As Storm draws nested instancers: every inner instance at every outer one, the
    transforms composed (USD's own ComputeInstanceTransformsAtTime at each level), and
    the image of the same boxes authored one by one."""
    stage = _nested()
    expected = _expected_worlds(stage)
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        nested = session.render()
        drawn = {}
        for inst in session.scene.instances.values():
            if inst.worlds is not None:
                mesh = inst.path.split("{", 1)[1].rstrip("}-")
                drawn.setdefault(mesh, []).extend(inst.worlds)
        inner = UsdGeom.PointInstancer(stage.GetPrimAtPath("/root/_protos/row/inner"))
        inner.GetPositionsAttr().Set([Gf.Vec3f(p[0], p[1] + 0.4, p[2]) for p in INNER])
        edited = session.render()                 # the inner instancer edited
    assert not nested.warnings, nested.warnings
    assert nested.stats["instances_drawn"] == 3 + 3 * 3
    for mesh, matrices in expected.items():
        want = sorted((np.array(m).T for m in matrices), key=lambda m: tuple(m[:3, 3]))
        got = sorted(drawn[mesh], key=lambda m: tuple(m[:3, 3]))
        assert len(got) == len(want)
        assert np.abs(np.array(got) - np.array(want)).max() < 1e-5
    alone = _render(_one_by_one(expected))
    diff = np.abs(nested.rgba - alone.rgba)[..., :3].max(axis=-1)
    hard_case("nested PointInstancer (3 x 3 inner instances, 3 outer meshes) vs the same "
              "boxes one by one: pixels differing by > 1e-3", int((diff > 1e-3).sum()), 5, "px")
    assert np.abs(edited.rgba - _render(stage).rgba).max() == 0.0
    assert np.abs(edited.rgba - nested.rgba).max() > 0.1


def test_an_instancer_inside_its_own_prototype_is_drawn_once_with_a_warning():
    stage = _nested()
    inner = UsdGeom.PointInstancer(stage.GetPrimAtPath("/root/_protos/row/inner"))
    inner.CreatePrototypesRel().SetTargets(["/root/_protos/row"])
    result = _render(stage)
    assert result.warnings == ["/root/_protos/row/inner: a PointInstancer inside its own "
                               "prototype; not drawn again there"]
    assert result.stats["instances_drawn"] == 3 + 3 * 3     # the row's box at each level
