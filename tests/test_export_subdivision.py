"""Subdivision surfaces exported as cages: scheme, levels, creases, boundary and UV rules."""
import numpy as np
import pytest
from pxr import Usd, UsdGeom

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


# --- the file default against Blender's own USD exporter --------------------------------

def _crease(ob, edges, vertex=None):
    """Blender crease values on edges 0 and 3 (and a vertex crease on point 5)."""
    me = ob.data
    values = np.zeros(len(me.edges), dtype=np.float32)
    values[[0, 3]] = edges
    me.attributes.new("crease_edge", "FLOAT", "EDGE").data.foreach_set("value", values)
    if vertex is not None:
        corners = np.zeros(len(me.vertices), dtype=np.float32)
        corners[5] = vertex
        me.attributes.new("crease_vert", "FLOAT", "POINT").data.foreach_set("value", corners)


def _suzanne_and_creased_cube():
    """Suzanne at level 2 and a cube with two creased edges (infinitely sharp and
    sharpness 2.5), subdivided at level 2, side by side."""
    import bpy
    bpy.ops.mesh.primitive_monkey_add(location=(-1.5, 0.0, 0.0))
    suzanne = bpy.context.active_object
    suzanne.name = "Suzanne"
    _subsurf(suzanne, levels=2, render_levels=2)
    bpy.ops.mesh.primitive_cube_add(location=(1.5, 0.0, 0.0), size=1.6)
    cube = bpy.context.active_object
    cube.name = "Creased"
    _crease(cube, (1.0, 0.5))
    _subsurf(cube, levels=2, render_levels=2)
    return suzanne, cube


def _mesh_facts(stage, name):
    """What both exporters say about the object's mesh: points, scheme, and the
    subdivision rules where the scheme has them."""
    mesh = mesh_prim(stage, name)
    facts = {"points": np.asarray(mesh.GetPointsAttr().Get()),
             "scheme": mesh.GetSubdivisionSchemeAttr().Get()}
    if facts["scheme"] == "catmullClark":
        for attr in ("CreaseIndices", "CreaseLengths", "CreaseSharpnesses", "CornerIndices",
                     "CornerSharpnesses", "InterpolateBoundary",
                     "FaceVaryingLinearInterpolation"):
            value = getattr(mesh, f"Get{attr}Attr")().Get()
            facts[attr] = value if isinstance(value, str) else list(value or [])
    return facts


@pytest.mark.parametrize("ours, blenders", [(None, "BEST_MATCH"), ("apply", "TESSELLATE"),
                                            ("ignore", "IGNORE")])
def test_each_mode_writes_what_blenders_usd_exporter_writes(empty_scene, tmp_path, ours,
                                                            blenders):
    """The default (cage), apply and ignore against bpy.ops.wm.usd_export's
    export_subdivision, on Blender's own cases for its rule: a last Catmull-Clark
    Subdivision Surface (Suzanne; a cube with edge and vertex creases), one followed by
    a Displace (applied), two in a row (the first applied, the last taken off) and
    Simple subdivision (applied). Points, scheme, creases, corners and boundary rules
    agree. Where they differ (a Subdivision Surface followed by a modifier that is
    off: Blender writes the cage as a polygon mesh), Lantern keeps the subdivision."""
    import bpy
    suzanne, _ = _suzanne_and_creased_cube()
    _crease(bpy.data.objects["Creased"], (1.0, 0.5), vertex=0.8)
    after = cube_object("After")
    _subsurf(after)
    after.modifiers.new("displace", "DISPLACE")
    two = cube_object("Two")
    _subsurf(two)
    _subsurf(two)
    simple = cube_object("Simple")
    _subsurf(simple).subdivision_type = "SIMPLE"
    off_after = cube_object("OffAfter")
    _subsurf(off_after)
    off = off_after.modifiers.new("displace", "DISPLACE")
    off.show_viewport = off.show_render = False
    stage, _ = export_current(ExportOptions() if ours is None else ExportOptions(subdivision=ours))
    path = str(tmp_path / "blender.usda")
    bpy.ops.wm.usd_export(filepath=path, export_subdivision=blenders, evaluation_mode="VIEWPORT",
                          export_materials=False)
    theirs = Usd.Stage.Open(path)
    names = ["Suzanne", "Creased", "After", "Two", "Simple", "OffAfter"]
    if ours is None:
        names.remove("OffAfter")
        mine, blender = _mesh_facts(stage, "OffAfter"), _mesh_facts(theirs, "OffAfter")
        assert len(mine["points"]) == len(blender["points"]) == 8
        assert (mine["scheme"], blender["scheme"]) == ("catmullClark", "none")
        assert len(mesh_prim(stage, "Suzanne").GetPointsAttr().Get()) == 507
    for name in names:
        mine, blender = _mesh_facts(stage, name), _mesh_facts(theirs, name)
        assert np.allclose(mine.pop("points"), blender.pop("points"), atol=1e-6), name
        assert mine == blender, name


def _lantern(*args):
    import subprocess
    import sys
    proc = subprocess.run([sys.executable, "-m", "lantern", *map(str, args)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]


def _world_level_5(ob):
    """Blender's own level-5 mesh of the object (Use Limit Surface), world space."""
    import bpy
    ob.modifiers["subsurf"].levels = 5
    bpy.context.view_layer.update()
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    try:
        co = np.empty(len(me.vertices) * 3, dtype=np.float64)
        me.vertices.foreach_get("co", co)
    finally:
        ev.to_mesh_clear()
    world = np.array(ob.matrix_world)
    return co.reshape(-1, 3) @ world[:3, :3].T + world[:3, 3]


def test_lantern_export_writes_cages_that_lantern_render_draws_on_blenders_surface(
        empty_scene, tmp_path):
    """`lantern export` with no option writes Suzanne (level 2) and a creased cube as
    catmullClark cages of 507 and 8 points with their creases; `lantern render` of the
    .blend renders what that file holds; the surface drawn from it (GPU tessellation
    at its cap) lies on Blender's own level-5 mesh within docs/subdivision.md's bounds
    (2e-3 of the diagonal near Suzanne's extraordinary vertices, exact where regular);
    `--subdivision apply` (here in a batch) writes the level-2 meshes."""
    import bpy
    from scipy.spatial import cKDTree

    from lantern.engine import RenderSettings, Session
    from lantern.engine.gpu.context import run_gl
    from lantern.engine.image_io import read_exr

    suzanne, cube = _suzanne_and_creased_cube()
    level_2 = {ob.name: len(ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.vertices)
               for ob in (suzanne, cube)}
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    _lantern("export", blend, "-o", tmp_path / "cage.usdc")
    # A batch (a folder for -o: the option reaches each file's own Blender process).
    _lantern("export", blend, "-o", tmp_path / "applied", "--subdivision", "apply", "-j", "1")

    stage = Usd.Stage.Open(str(tmp_path / "cage.usdc"))
    for name, points in (("Suzanne", 507), ("Creased", 8)):
        mesh = mesh_prim(stage, name)
        assert len(mesh.GetPointsAttr().Get()) == points
        assert mesh.GetSubdivisionSchemeAttr().Get() == "catmullClark"
    creased = mesh_prim(stage, "Creased")
    expected = [tuple(cube.data.edges[i].vertices) for i in (0, 3)]
    assert [tuple(p) for p in np.reshape(creased.GetCreaseIndicesAttr().Get(), (-1, 2))] == expected
    assert np.allclose(creased.GetCreaseSharpnessesAttr().Get(), [10.0, 2.5])
    applied = Usd.Stage.Open(str(tmp_path / "applied" / "scene.usdc"))
    for name in ("Suzanne", "Creased"):
        mesh = mesh_prim(applied, name)
        assert len(mesh.GetPointsAttr().Get()) == level_2[name]
        assert mesh.GetSubdivisionSchemeAttr().Get() == "none"

    # What `lantern render` draws of the .blend is what it draws of the file.
    _lantern("render", blend, "-o", tmp_path / "blend.exr", "--size", "64x48")
    _lantern("render", tmp_path / "cage.usdc", "-o", tmp_path / "file.exr", "--size", "64x48")
    from_blend, from_file = read_exr(str(tmp_path / "blend.exr")), read_exr(str(tmp_path / "file.exr"))
    assert from_blend[..., :3].max() > 0.01
    assert np.abs(from_blend - from_file).max() == 0.0

    # The surface the renderer draws from the file, against Blender's level 5.
    bounds = {"Suzanne": 2e-3, "Creased": 4e-3}
    theirs = {ob.name: _world_level_5(ob) for ob in (suzanne, cube)}
    with Session(stage, RenderSettings(width=64, height=48, tessellation_px=1e-3)) as session:
        assert session.render().stats["meshes_tessellated"] == 2
        renderer = session._renderer
        drawn = {}
        for key in renderer.tessellation.meshes:
            data = run_gl(lambda gl: renderer.tessellation.read(key)).astype(np.float64)
            inst = next(i for i in session.scene.instances.values() if i.mesh_key == key)
            name = inst.path.split("/")[2]
            drawn[name] = data[:, :3] @ inst.world[:3, :3].T + inst.world[:3, 3]
    assert sorted(drawn) == sorted(bounds)
    for name, ours in drawn.items():
        blender = theirs[name]
        diag = np.linalg.norm(blender.max(axis=0) - blender.min(axis=0))
        dist = cKDTree(blender).query(ours)[0] / diag
        print(f"{name}: {len(ours)} corners, median {np.median(dist):.1e}, "
              f"max {dist.max():.1e} of the diagonal")
        assert np.median(dist) < 1e-6 and dist.max() < bounds[name], name


def _suzanne_and_cube_with_a_creased_face(render_level):
    """Suzanne (level 2, smooth) and a smooth cube whose four edges round its back face
    are creased (crease 1.0), lit by a sun, seen by a camera that frames both."""
    import math

    import bpy
    bpy.ops.mesh.primitive_monkey_add(location=(-1.3, 0.0, 0.0))
    suzanne = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_cube_add(location=(1.3, 0.0, 0.0), size=1.6, rotation=(0.3, 0.2, 0.5))
    cube = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    me = cube.data
    face = set(next(p for p in me.polygons if p.normal.y > 0.9).vertices)   # away from the camera
    creases = np.array([float(set(e.vertices) <= face) for e in me.edges], np.float32)
    assert creases.sum() == 4
    me.attributes.new("crease_edge", "FLOAT", "EDGE").data.foreach_set("value", creases)
    for ob in (suzanne, cube):
        _subsurf(ob, levels=render_level, render_levels=render_level)
    scene = bpy.context.scene
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0.0, -7.0, 1.2), (math.radians(80), 0.0, 0.0)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 10.0
    sun.rotation_euler = (math.radians(40), math.radians(20), math.radians(-30))
    for ob in (camera, sun):
        scene.collection.objects.link(ob)
    scene.camera = camera


def test_rendered_cage_looks_like_blenders_level_5(empty_scene, tmp_path):
    """Suzanne at level 2 and a cube with a creased face, exported as cages by `lantern
    export` and rendered by `lantern render` at 320x180, against the same objects with
    the modifier applied at level 5: mean |difference| at most 5e-3 and 99.5th
    percentile at most 0.4 (measured 2026-11-28: 3.6e-3 and 0.095; level 4 against 5,
    2.0e-3 and 0.062; level 3, 6.9e-3 and 0.385). The surfaces cast their shadows in
    the first frame (without them 1.0e-2 and 0.47), and curved patch edges are cut
    finer than the pixel target alone would (without that 5.3e-3 and 0.148)."""
    import bpy

    from lantern.engine.image_io import read_exr
    images = {}
    for name, level, option in (("cage", 2, "cage"), ("level5", 5, "apply")):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        _suzanne_and_cube_with_a_creased_face(level)
        blend = tmp_path / f"{name}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(blend))
        _lantern("export", blend, "-o", tmp_path / f"{name}.usdc", "--subdivision", option)
        _lantern("render", tmp_path / f"{name}.usdc", "-o", tmp_path / f"{name}.exr",
                 "--size", "320x180")
        images[name] = read_exr(str(tmp_path / f"{name}.exr"))[..., :3]
    stage = Usd.Stage.Open(str(tmp_path / "cage.usdc"))
    assert len(mesh_prim(stage, "Suzanne").GetPointsAttr().Get()) == 507
    diff = np.abs(images["cage"] - images["level5"])
    mean, tail = diff.mean(), np.percentile(diff, 99.5)
    print(f"cage against level 5: mean {mean:.2e}, 99.5th percentile {tail:.3f}, "
          f"{int((diff.max(axis=-1) > 0.5).sum())} pixels over 0.5")
    assert images["level5"].mean() > 0.05
    assert mean <= 5e-3 and tail <= 0.4
