"""CPU Catmull-Clark refinement (engine/subdivision.py) against Blender's Subdivision
Surface modifier without its limit-surface step: the same rules give the same points."""
import bpy
import numpy as np
import pytest

from _export_helpers import cube_object, vectors
from lantern.engine.subdivision import cage, refine
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


def _blender_refined(ob, levels):
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels = mod.render_levels = levels
    mod.use_limit_surface = False
    bpy.context.view_layer.update()
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    try:
        return vectors(me.vertices, "co"), len(me.polygons)
    finally:
        ev.to_mesh_clear()


def _max_nearest(a, b):
    """Symmetric largest distance from a row of one set to the nearest row of the other."""
    def one_way(x, y):
        return max(np.sqrt(((x[i:i + 512, None, :] - y[None]) ** 2).sum(axis=2)).min(axis=1).max()
                   for i in range(0, len(x), 512))
    return max(one_way(a, b), one_way(b, a))


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


def test_exported_cage_refined_by_the_engine_matches_blender(empty_scene):
    """Export (cage, creases, level) -> stage -> engine refinement = Blender's mesh."""
    from pxr import Usd, UsdGeom

    from _export_helpers import export_current
    from lantern.engine.usd.subdivision import RefinedCage, subdivision_level
    from lantern.exporters.api import ExportOptions

    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.active_object
    me = ob.data
    creases = np.zeros(len(me.edges), dtype=np.float32)
    creases[:40:3] = 0.6
    me.attributes.new("crease_edge", "FLOAT", "EDGE").data.foreach_set("value", creases)
    theirs, _ = _blender_refined(ob, 2)
    stage, _ = export_current(ExportOptions(subdivision="cage"))
    prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    assert subdivision_level(prim, []) == 2
    mesh = UsdGeom.Mesh(prim)
    t = Usd.TimeCode.Default()
    refined = RefinedCage(mesh, np.asarray(mesh.GetPointsAttr().Get(), np.float64),
                          np.asarray(mesh.GetFaceVertexCountsAttr().Get(), np.int64),
                          np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), np.int64), 2, t)
    assert len(refined.points) == len(theirs)
    assert _max_nearest(refined.points, theirs) < 1e-5


def test_uvs_across_a_seam_match_blender_with_linear_uv_smoothing(empty_scene):
    """UV Smooth None (faceVaryingLinearInterpolation all): each refined corner's (point,
    UV) pair is one of Blender's; Suzanne's UV map has seams and open boundaries."""
    from lantern.engine.subdivision import refine_face_varying

    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.active_object
    me = ob.data
    c = _blender_cage(ob)
    uv = vectors(me.uv_layers.active.uv, "vector", 2).astype(np.float64)
    ours = refine(c, 1)
    ours_uv = refine_face_varying(c.counts, uv, 1)
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels, mod.use_limit_surface, mod.uv_smooth = 1, False, "NONE"
    bpy.context.view_layer.update()
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    out = ev.to_mesh()
    try:
        pts = vectors(out.vertices, "co")
        theirs = np.concatenate([pts[[l.vertex_index for l in out.loops]],
                                 vectors(out.uv_layers.active.uv, "vector", 2)], axis=1)
    finally:
        ev.to_mesh_clear()
    mine = np.concatenate([ours.points[ours.indices], ours_uv], axis=1)
    assert len(mine) == len(theirs)
    assert _max_nearest(mine, theirs) < 1e-5
