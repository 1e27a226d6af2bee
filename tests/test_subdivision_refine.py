"""CPU Catmull-Clark refinement (engine/subdivision.py) against Blender's Subdivision
Surface modifier, with and without its limit-surface step: the same rules give the same
points."""
import bpy
import numpy as np
import pytest

from _export_helpers import cube_object, vectors
from lantern.engine.subdivision import cage, refine, refine_face_varying
from lantern.exporters.gather.subdivision import crease_to_sharpness


def _blender_cage(ob):
    me = ob.data
    counts = np.array([p.loop_total for p in me.polygons])
    indices = np.array([l.vertex_index for l in me.loops])
    pairs, sharp, corners, corner_sharp = [], [], [], []
    if "crease_edge" in me.attributes:
        for e, a in zip(me.edges, me.attributes["crease_edge"].data):
            if a.value > 0:
                pairs.append(tuple(e.vertices))
                sharp.append(float(crease_to_sharpness(a.value)))
    if "crease_vert" in me.attributes:
        for i, a in enumerate(me.attributes["crease_vert"].data):
            if a.value > 0:
                corners.append(i)
                corner_sharp.append(float(crease_to_sharpness(a.value)))
    return cage(vectors(me.vertices, "co"), counts, indices, pairs, sharp, corners,
                corner_sharp)


QUALITY = 3      # the modifier's default (its adaptive isolation level)


def _blender_refined(ob, levels, limit=False):
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels = mod.render_levels = levels
    mod.use_limit_surface = limit
    mod.quality = QUALITY
    bpy.context.view_layer.update()
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    try:
        return vectors(me.vertices, "co"), len(me.polygons)
    finally:
        ev.to_mesh_clear()


def _max_nearest(a, b):
    """Symmetric largest distance from a row of one set to the nearest row of the other."""
    from scipy.spatial import cKDTree
    return max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max())


def test_a_cages_edges_are_its_distinct_vertex_pairs_in_order():
    """The edges a cage's rules run over (found as one integer per pair): each distinct
    pair of neighbouring corners once, lower vertex first, in the pairs' order, on
    polygons of mixed sizes over vertex numbers far apart, and on no faces at all."""
    counts = np.array([3, 4, 5, 4])
    indices = np.array([7, 900000, 3, 3, 900000, 12, 5, 5, 12, 8, 2, 40, 7, 3, 5, 2])
    pairs = np.sort(np.stack([indices, indices[[1, 2, 0, 4, 5, 6, 3, 8, 9, 10, 11, 7,
                                                13, 14, 15, 12]]], 1), axis=1)
    points = np.zeros((900001, 3))
    assert np.array_equal(cage(points, counts, indices).edges, np.unique(pairs, axis=0))
    assert cage(points, np.zeros(0, np.int64), np.zeros(0, np.int64)).edges.shape == (0, 2)


@pytest.mark.parametrize("levels", [1, 2])
def test_cube_matches_blender(empty_scene, levels):
    ob = cube_object("Cube")
    ours = refine(_blender_cage(ob), levels)
    theirs, faces = _blender_refined(ob, levels)
    assert len(ours.points) == len(theirs) and len(ours.counts) == faces
    assert _max_nearest(ours.points, theirs) < 1e-5


def test_suzanne_with_triangles_and_open_boundary_matches_blender(empty_scene):
    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.active_object
    ours = refine(_blender_cage(ob), 2)
    theirs, faces = _blender_refined(ob, 2)
    assert len(ours.points) == len(theirs)
    assert _max_nearest(ours.points, theirs) < 1e-5


def test_creases_and_corner_match_blender(empty_scene):
    ob = cube_object("Creased")
    me = ob.data
    creases = np.zeros(len(me.edges), dtype=np.float32)
    creases[[0, 3, 5]] = (1.0, 0.5, 0.8)
    me.attributes.new("crease_edge", "FLOAT", "EDGE").data.foreach_set("value", creases)
    corners = np.zeros(len(me.vertices), dtype=np.float32)
    corners[6] = 0.7
    me.attributes.new("crease_vert", "FLOAT", "POINT").data.foreach_set("value", corners)
    creased = _blender_cage(ob)
    ours = refine(creased, 3)
    theirs, _ = _blender_refined(ob, 3)
    assert _max_nearest(ours.points, theirs) < 1e-5
    # The creases matter: without them the surface is far from Blender's.
    plain = refine(cage(creased.points, creased.counts, creased.indices), 3)
    assert _max_nearest(plain.points, theirs) > 1e-2


@pytest.mark.parametrize("limit", [False, True])
def test_exported_cage_refined_by_the_engine_matches_blender(empty_scene, limit):
    """Export (cage, creases, level, Use Limit Surface) -> stage -> engine refinement =
    Blender's mesh."""
    from pxr import Usd, UsdGeom

    from _export_helpers import export_current
    from lantern.engine.usd.subdivision import RefinedCage, subdivision_level
    from lantern.exporters.api import ExportOptions

    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.active_object
    me = ob.data
    creases = np.zeros(len(me.edges), dtype=np.float32)
    # With the limit step, infinitely sharp creases: Blender's limit at the ends of a
    # semi-sharp crease (a dart) differs from the exact limit by up to 1% of the
    # diagonal (docs/subdivision.md), and at infinitely sharp ones by 1e-4.
    creases[:40:3] = 1.0 if limit else 0.6
    me.attributes.new("crease_edge", "FLOAT", "EDGE").data.foreach_set("value", creases)
    theirs, _ = _blender_refined(ob, 2, limit)
    stage, _ = export_current(ExportOptions(subdivision="cage"))
    prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    assert subdivision_level(prim, []) == 2
    mesh = UsdGeom.Mesh(prim)
    t = Usd.TimeCode.Default()
    refined = RefinedCage(mesh, np.asarray(mesh.GetPointsAttr().Get(), np.float64),
                          np.asarray(mesh.GetFaceVertexCountsAttr().Get(), np.int64),
                          np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), np.int64), 2, t)
    assert len(refined.points) == len(theirs)
    diag = np.linalg.norm(theirs.max(axis=0) - theirs.min(axis=0))
    assert _max_nearest(refined.points, theirs) < (1e-4 * diag if limit else 1e-5)
    assert prim.GetAttribute("lantern:subdivisionLimitSurface").IsValid() == (not limit)


def _corner_pairs(ob):
    """Blender's evaluated (point, UV) of every face corner, (C, 5)."""
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    out = ev.to_mesh()
    try:
        loops = np.empty(len(out.loops), np.int64)
        out.loops.foreach_get("vertex_index", loops)
        return np.concatenate([vectors(out.vertices, "co")[loops],
                               vectors(out.uv_layers.active.uv, "vector", 2)], axis=1)
    finally:
        ev.to_mesh_clear()


@pytest.mark.parametrize("uv_smooth", ["NONE", "PRESERVE_BOUNDARIES", "PRESERVE_CORNERS",
                                       "PRESERVE_CORNERS_AND_JUNCTIONS", "SMOOTH_ALL"])
@pytest.mark.parametrize("limit", [False, True])
def test_uvs_follow_blenders_uv_smooth(empty_scene, uv_smooth, limit):
    """Exported with its UV Smooth rule, Suzanne's cage refined by the engine gives
    Blender's (point, UV) at every face corner of level 2, across its seams and open
    boundaries. Smooth All with the limit step: Blender's UVs at the channel's boundary
    corners differ from the crease limit by up to 3e-4 (a bound of 1e-3 there)."""
    from pxr import Usd, UsdGeom

    from _export_helpers import export_current
    from lantern.engine.usd.subdivision import RefinedCage
    from lantern.exporters.api import ExportOptions

    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.active_object
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels = mod.render_levels = 2
    mod.use_limit_surface, mod.uv_smooth = limit, uv_smooth
    theirs = _corner_pairs(ob)
    stage, _ = export_current(ExportOptions(subdivision="cage"))
    prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    mesh, t = UsdGeom.Mesh(prim), Usd.TimeCode.Default()
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(), np.int64)
    indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), np.int64)
    refined = RefinedCage(mesh, np.asarray(mesh.GetPointsAttr().Get(), np.float64), counts,
                          indices, 2, t)
    primvar = next(p for p in UsdGeom.PrimvarsAPI(mesh).GetPrimvars()
                   if p.GetTypeName() == "texCoord2f[]")
    uv = np.asarray(primvar.ComputeFlattened(t), np.float64)
    mine = np.concatenate([refined.points[refined.indices], refined.face_varying(uv)], axis=1)
    assert len(mine) == len(theirs)
    bound = 1e-3 if (uv_smooth, limit) == ("SMOOTH_ALL", True) else 1e-5
    assert _max_nearest(mine, theirs) < bound
    if uv_smooth != "NONE":     # the rule matters: linear UVs are far from Blender's
        linear = refine_face_varying(counts, uv, 2)
        assert _max_nearest(np.concatenate([mine[:, :3], linear], axis=1), theirs) > 1e-3


def _shape(shape, creases=None):
    """Suzanne, or a cube with edges 0 and 3 creased (Blender's crease values)."""
    if shape == "suzanne":
        bpy.ops.mesh.primitive_monkey_add()
        ob = bpy.context.active_object
    else:
        ob = cube_object(shape)
    if creases is not None:
        me = ob.data
        values = np.zeros(len(me.edges), dtype=np.float32)
        values[[0, 3]] = creases
        me.attributes.new("crease_edge", "FLOAT", "EDGE").data.foreach_set("value", values)
    return ob


def _blender_limit(ob, levels):
    return _blender_refined(ob, levels, limit=True)[0]


@pytest.mark.parametrize("shape, levels, creases", [
    ("cube", 2, None), ("suzanne", 2, None),
    ("creased", 2, (0.5, 0.0)),   # sharpness 2.5: 0.5 left at level 2, refined past
    ("creased", 3, (1.0, 0.3)),   # infinitely sharp, and one gone after level 1
])
def test_limit_points_match_blenders_limit_surface(empty_scene, shape, levels, creases):
    """Use Limit Surface (Blender's default): the refined points moved onto the limit
    surface are Blender's (its numbering differs with the limit step on). Not asserted:
    the two ends of an infinitely sharp crease on a cube (darts) at level 2, where
    Blender's patch evaluation differs from the smooth limit by 0.3% of the diagonal,
    and agrees again from level 3."""
    from lantern.engine.subdivision import limit_points

    ob = _shape(shape, creases)
    refined = refine(_blender_cage(ob), levels)
    theirs = _blender_limit(ob, levels)
    ours = limit_points(refined)
    assert len(ours) == len(theirs)
    diag = np.linalg.norm(theirs.max(axis=0) - theirs.min(axis=0))
    assert _max_nearest(ours, theirs) < 1e-5 * diag
    # The step matters: the refined points themselves lie inside the limit surface.
    assert _max_nearest(refined.points, theirs) > 1e-3 * diag


@pytest.mark.parametrize("shape, creases, bound", [
    ("cube", None, 2e-3), ("suzanne", None, 2e-3),
    ("creased", (1.0, 1.0), 4e-3),     # two infinitely sharp edges
    ("creased", (0.5, 0.0), 2e-3),     # sharpness 2.5: patches after 3 refinements
])
def test_patches_match_blenders_level_5(empty_scene, shape, creases, bound):
    """The surface the GPU tessellates (the exported cage's Bezier patches) against
    Blender's Subdivision Surface at level 5 with Use Limit Surface: each patch evaluated
    where Blender's level-5 points lie, nearest-point distances. Regular patches lie on
    Blender's points to float rounding (bound 1e-5 of the bounding-box diagonal; the
    stated bound is 1e-3); patches at an extraordinary vertex or a boundary within 2e-3
    (measured 1.2e-3 on the cube, 1.3e-3 on Suzanne), beside the end of an infinitely
    sharp crease within 4e-3 (measured 2.6e-3 and 3.2e-3)."""
    from pxr import Usd, UsdGeom
    from scipy.spatial import cKDTree

    from _export_helpers import export_current
    from lantern.engine.bezier_patches import evaluate
    from lantern.engine.subdivision import vertex_rules
    from lantern.engine.usd.subdivision import PATCH_LEVELS, RefinedCage
    from lantern.exporters.api import ExportOptions

    ob = _shape(shape, creases)
    theirs, _ = _blender_refined(ob, 5, limit=True)
    stage, _ = export_current(ExportOptions(subdivision="cage"))
    prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    mesh, t = UsdGeom.Mesh(prim), Usd.TimeCode.Default()
    refined = RefinedCage(mesh, np.asarray(mesh.GetPointsAttr().Get(), np.float64),
                          np.asarray(mesh.GetFaceVertexCountsAttr().Get(), np.int64),
                          np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), np.int64), 5, t,
                          patches=True)
    assert refined.levels == (3 if creases == (0.5, 0.0) else PATCH_LEVELS)
    steps = np.linspace(0.0, 1.0, 2 ** (5 - refined.levels) + 1)
    u, v = np.meshgrid(steps, steps)
    ours = evaluate(refined.patches.reshape(-1, 16, 3), u, v).reshape(len(refined.patches), -1, 3)
    ob.modifiers.clear()
    c = refine(_blender_cage(ob), refined.levels)
    quads = c.indices.reshape(-1, 4)
    rule, edges, _ = vertex_rules(c)
    valence = np.bincount(edges.ravel(), minlength=len(c.points))
    regular = ((valence[quads] == 4) & (rule[quads] == 0)).all(axis=1)
    diag = np.linalg.norm(theirs.max(axis=0) - theirs.min(axis=0))
    dist = cKDTree(theirs).query(ours.reshape(-1, 3))[0].reshape(len(ours), -1) / diag
    back = cKDTree(ours.reshape(-1, 3)).query(theirs)[0] / diag
    assert regular.sum() > 0.5 * len(regular)
    assert dist[regular].max() < 1e-5
    assert dist[~regular].max() < bound and back.max() < bound


def test_skinned_cage_is_refined_after_its_skinning(empty_scene):
    """A tube skinned by a three-bone chain, subdivided after its Armature modifier, is
    exported as a skinned cage; the GPU skins the cage, makes its patches from the
    skinned points and tessellates them. At a posed frame the triangles' corners lie on
    Blender's level-5 points (armature, then Subdivision Surface with its limit step)."""
    from scipy.spatial import cKDTree

    from _export_helpers import (add_armature_modifier, animate_pose, blender_world_points,
                                 export_current, make_armature, make_tube, weight_by_height)
    from lantern.engine import RenderSettings, Session
    from lantern.engine.gpu.context import run_gl
    from lantern.exporters.api import ExportOptions
    from pxr import UsdGeom, UsdSkel

    bones = ("Bone0", "Bone1", "Bone2")
    arm = make_armature("Rig", bones)
    tube = make_tube("Rig_Body")
    weight_by_height(tube, bones)
    add_armature_modifier(tube, arm)
    mod = tube.modifiers.new("subsurf", "SUBSURF")
    mod.levels = mod.render_levels = 4           # the GPU's cap: level 5's grid (2 + 3)
    animate_pose(arm, frames=range(1, 4))
    n_cage = len(tube.data.vertices)
    stage, report = export_current(ExportOptions(subdivision="cage"))
    prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    assert prim.HasAPI(UsdSkel.BindingAPI)
    assert UsdGeom.Mesh(prim).GetSubdivisionSchemeAttr().Get() == "catmullClark"
    assert len(UsdGeom.Mesh(prim).GetPointsAttr().Get()) == n_cage

    mod.levels = mod.render_levels = 5
    bpy.context.scene.frame_set(3)
    theirs = blender_world_points(tube)
    diag = np.linalg.norm(theirs.max(axis=0) - theirs.min(axis=0))
    with Session(stage, RenderSettings(width=64, height=48, frame=3,
                                       tessellation_px=1e-3)) as s:
        res = s.render()
        assert not [w for w in res.warnings if "subdivision" in w], res.warnings
        assert res.stats["meshes_skinned"] == 1 and res.stats["meshes_tessellated"] == 1
        key = next(iter(s._renderer.tessellation.meshes))
        data = run_gl(lambda gl: s._renderer.tessellation.read(key))
        world = next(i.world for i in s.scene.instances.values() if i.mesh_key == key)
        rest = s.scene.meshes[key].patches.control.reshape(-1, 3).astype(np.float64)
    ours = data[:, :3].astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    dist = cKDTree(theirs).query(ours)[0] / diag
    back = cKDTree(ours).query(theirs)[0] / diag
    assert dist.max() < 1e-4 and back.max() < 1e-4, (dist.max(), back.max())
    # The pose matters: the rest patches are far from the posed surface.
    rest_world = rest @ world[:3, :3].T + world[:3, 3]
    assert cKDTree(theirs).query(rest_world)[0].max() / diag > 0.05
    # The CPU path cannot refine after the GPU's skinning: the cage, and one warning.
    with Session(stage, RenderSettings(width=64, height=48, frame=3, tessellation_px=0)) as s:
        res = s.render()
        assert [w for w in res.warnings if "skinned subdivision cage" in w] == [
            f"{prim.GetPath()}: a skinned subdivision cage is refined only by GL 4.3's "
            "tessellation, with Use Limit Surface; drawn as its cage"]
        assert "tessellation" not in res.stats["passes"]


def test_tessellated_surface_matches_blenders_level_5(empty_scene):
    """Blender's cube (UV seams on six islands) with Keep Boundaries UV smoothing,
    exported as a cage and tessellated by the GPU: its (point, UV) at every tessellated
    corner against Blender's level-5 face corners. Exact away from extraordinary
    vertices (median), within the patches' bound near them (2e-3 of the diagonal; the
    UVs' own patches likewise). Suzanne is measured through its patches above
    (test_patches_match_blenders_level_5), which the GPU's triangles equal
    (tests/test_tessellation.py): tessellating it at level 5's grid here takes llvmpipe
    minutes."""
    from scipy.spatial import cKDTree

    from _export_helpers import export_current
    from lantern.engine import RenderSettings, Session
    from lantern.engine.gpu.context import run_gl
    from lantern.exporters.api import ExportOptions

    bpy.ops.mesh.primitive_cube_add()
    ob = bpy.context.active_object
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels = mod.render_levels = 4          # the GPU's cap: level 5's grid (2 + 3)
    assert mod.uv_smooth == "PRESERVE_BOUNDARIES" and mod.use_limit_surface
    stage, _ = export_current(ExportOptions(subdivision="cage"))
    mod.levels = 5
    theirs = _corner_pairs(ob)
    with Session(stage, RenderSettings(width=64, height=48, tessellation_px=1e-3)) as s:
        s.render()
        key = next(iter(s._renderer.tessellation.meshes))
        data = run_gl(lambda gl: s._renderer.tessellation.read(key)).astype(np.float64)
    ours = np.concatenate([data[:, :3], data[:, 6:8]], axis=1)
    diag = np.linalg.norm(theirs[:, :3].max(axis=0) - theirs[:, :3].min(axis=0))
    dist = cKDTree(theirs).query(ours)[0] / diag
    assert np.median(dist) < 1e-6 and dist.max() < 2e-3
    uv_only = cKDTree(theirs).query(np.concatenate([data[:, :3], 0 * data[:, 6:8]], axis=1))[0]
    assert uv_only.max() > 0.1          # the UVs are part of what is compared
