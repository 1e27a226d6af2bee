"""Subdivision surfaces exported as cages: scheme, levels, creases, boundary and UV rules."""
import numpy as np
from pxr import UsdGeom

from _export_helpers import cube_object, export_current
from lantern.exporters.api import ExportOptions

CAGE = ExportOptions(subdivision="cage")


def mesh_prim(stage, object_name):
    obj = stage.GetPrimAtPath(f"/root/{object_name}")
    return UsdGeom.Mesh(next(c for c in obj.GetChildren() if c.IsA(UsdGeom.Mesh)))


def _subsurf(ob, levels=1, render_levels=3):
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels, mod.render_levels = levels, render_levels
    return mod


def test_cage_is_written_with_scheme_levels_and_rules(empty_scene):
    ob = cube_object("Sub")
    mod = _subsurf(ob)
    mod.boundary_smooth = "PRESERVE_CORNERS"
    mod.uv_smooth = "PRESERVE_BOUNDARIES"
    stage, _ = export_current(CAGE)
    mesh = mesh_prim(stage, "Sub")
    assert len(mesh.GetPointsAttr().Get()) == 8
    assert len(mesh.GetFaceVertexCountsAttr().Get()) == 6
    assert mesh.GetSubdivisionSchemeAttr().Get() == "catmullClark"
    assert mesh.GetInterpolateBoundaryAttr().Get() == "edgeAndCorner"
    assert mesh.GetFaceVaryingLinearInterpolationAttr().Get() == "boundaries"
    prim = mesh.GetPrim()
    assert prim.GetAttribute("lantern:subdivisionRenderLevel").Get() == 3
    assert prim.GetAttribute("lantern:subdivisionViewportLevel").Get() == 1
    assert not mesh.GetCreaseIndicesAttr().HasAuthoredValue()


def test_creases_and_corners_are_written_as_sharpness(empty_scene):
    ob = cube_object("Creased")
    me = ob.data
    edge = me.attributes.new("crease_edge", "FLOAT", "EDGE")
    creases = np.zeros(len(me.edges), dtype=np.float32)
    creases[[0, 3]] = (1.0, 0.5)
    edge.data.foreach_set("value", creases)
    vert = me.attributes.new("crease_vert", "FLOAT", "POINT")
    corners = np.zeros(len(me.vertices), dtype=np.float32)
    corners[5] = 0.8
    vert.data.foreach_set("value", corners)
    _subsurf(ob)
    stage, _ = export_current(CAGE)
    mesh = mesh_prim(stage, "Creased")
    pairs = np.array(mesh.GetCreaseIndicesAttr().Get()).reshape(-1, 2)
    expected = np.array([tuple(me.edges[i].vertices) for i in (0, 3)])
    assert np.array_equal(pairs, expected)
    assert list(mesh.GetCreaseLengthsAttr().Get()) == [2, 2]
    assert np.allclose(mesh.GetCreaseSharpnessesAttr().Get(), [10.0, 2.5])
    assert list(mesh.GetCornerIndicesAttr().Get()) == [5]
    assert np.allclose(mesh.GetCornerSharpnessesAttr().Get(), [6.4])


def test_creases_off_in_the_modifier_are_not_written(empty_scene):
    ob = cube_object("NoCrease")
    me = ob.data
    me.attributes.new("crease_edge", "FLOAT", "EDGE").data.foreach_set(
        "value", np.ones(len(me.edges), dtype=np.float32))
    _subsurf(ob).use_creases = False
    stage, _ = export_current(CAGE)
    mesh = mesh_prim(stage, "NoCrease")
    assert not mesh.GetCreaseIndicesAttr().HasAuthoredValue()


def test_modifier_before_subdivision_is_applied_into_the_cage(empty_scene):
    ob = cube_object("Mirrored")
    ob.modifiers.new("mirror", "MIRROR").use_mirror_merge = False
    _subsurf(ob)
    stage, _ = export_current(CAGE)
    mesh = mesh_prim(stage, "Mirrored")
    assert len(mesh.GetPointsAttr().Get()) == 16
    assert mesh.GetSubdivisionSchemeAttr().Get() == "catmullClark"
    assert ob.modifiers["subsurf"].show_viewport  # switched back on


def test_modifier_after_subdivision_applies_it(empty_scene):
    ob = cube_object("Displaced")
    _subsurf(ob, levels=2)
    ob.modifiers.new("displace", "DISPLACE")
    stage, _ = export_current(CAGE)
    mesh = mesh_prim(stage, "Displaced")
    assert len(mesh.GetPointsAttr().Get()) > 8
    assert mesh.GetSubdivisionSchemeAttr().Get() == "none"


def test_simple_subdivision_is_applied(empty_scene):
    ob = cube_object("Simple")
    _subsurf(ob, levels=2).subdivision_type = "SIMPLE"
    stage, _ = export_current(CAGE)
    mesh = mesh_prim(stage, "Simple")
    assert mesh.GetSubdivisionSchemeAttr().Get() == "none"
    assert len(mesh.GetPointsAttr().Get()) > 8
