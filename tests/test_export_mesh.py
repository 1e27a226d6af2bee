"""Meshes: evaluated geometry, normals, UVs, material subsets, shared data, hierarchy."""
import bpy
import numpy as np
from mathutils import Matrix
from pxr import Gf, UsdGeom, UsdShade

from _export_helpers import cube_object, evaluated_mesh_data, export_current, vectors
from lantern.exporters.api import ExportOptions


def mesh_prim(stage, object_name):
    obj = stage.GetPrimAtPath(f"/root/{object_name}")
    meshes = [c for c in obj.GetChildren() if c.IsA(UsdGeom.Mesh)]
    assert len(meshes) == 1
    return UsdGeom.Mesh(meshes[0])


def test_subsurf_exports_the_evaluated_points(empty_scene):
    ob = cube_object("Sub")
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels = mod.render_levels = 2
    expected = evaluated_mesh_data(ob, lambda m: len(m.vertices))
    assert expected > 8
    stage, _ = export_current(ExportOptions(subdivision="apply"))
    mesh = mesh_prim(stage, "Sub")
    assert len(mesh.GetPointsAttr().Get()) == expected
    assert mesh.GetSubdivisionSchemeAttr().Get() == "none"
    assert mesh.GetExtentAttr().HasAuthoredValue()


def test_custom_normals_are_face_varying_corner_normals(empty_scene):
    ob = cube_object("Custom")
    me = ob.data
    me.shade_smooth()
    # Custom split normals: every corner gets its face's normal, as a flat cube.
    face_normals = vectors(me.polygons, "normal")
    corner_faces = np.repeat(np.arange(len(me.polygons)), [p.loop_total for p in me.polygons])
    me.normals_split_custom_set([tuple(face_normals[f]) for f in corner_faces])
    expected = evaluated_mesh_data(ob, lambda m: vectors(m.corner_normals))
    stage, _ = export_current()
    mesh = mesh_prim(stage, "Custom")
    assert mesh.GetNormalsInterpolation() == UsdGeom.Tokens.faceVarying
    normals = np.array(mesh.GetNormalsAttr().Get())
    assert normals.shape == (24, 3)
    np.testing.assert_allclose(normals, expected, atol=1e-6)
    np.testing.assert_allclose(normals, face_normals[corner_faces], atol=1e-5)


def test_smooth_sphere_has_vertex_normals(empty_scene):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8)
    ob = bpy.context.active_object
    ob.name = "Sphere"
    ob.data.shade_smooth()
    expected = evaluated_mesh_data(ob, lambda m: vectors(m.vertex_normals))
    stage, _ = export_current()
    mesh = mesh_prim(stage, "Sphere")
    assert mesh.GetNormalsInterpolation() == UsdGeom.Tokens.vertex
    np.testing.assert_allclose(np.array(mesh.GetNormalsAttr().Get()), expected, atol=1e-6)


def test_two_uv_maps_are_both_exported(empty_scene):
    ob = cube_object("UVs")
    first, second = ob.data.uv_layers.new(name="UVMap"), ob.data.uv_layers.new(name="Second map")
    rng = np.random.default_rng(1)
    for layer in (first, second):
        layer.uv.foreach_set("vector", rng.random(48).astype(np.float32))
    stage, _ = export_current()
    primvars = UsdGeom.PrimvarsAPI(mesh_prim(stage, "UVs"))
    for layer, name in ((first, "UVMap"), (second, "Second_map")):
        pv = primvars.GetPrimvar(name)
        assert pv and pv.GetInterpolation() == UsdGeom.Tokens.faceVarying
        assert pv.GetTypeName() == "texCoord2f[]"
        np.testing.assert_allclose(np.array(pv.Get()), vectors(layer.uv, width=2))


def test_two_materials_make_subsets_covering_every_face_once(empty_scene):
    ob = cube_object("TwoMats")
    red, blue = bpy.data.materials.new("Red"), bpy.data.materials.new("Blue")
    ob.data.materials.append(red)
    ob.data.materials.append(blue)
    ob.data.polygons.foreach_set("material_index", [0, 1, 0, 1, 1, 0])
    stage, _ = export_current()
    mesh = mesh_prim(stage, "TwoMats")
    subsets = UsdGeom.Subset.GetGeomSubsets(mesh, UsdGeom.Tokens.face, "materialBind")
    assert len(subsets) == 2
    assert UsdGeom.Subset.GetFamilyType(mesh, "materialBind") == UsdGeom.Tokens.nonOverlapping
    faces = sorted(i for s in subsets for i in s.GetIndicesAttr().Get())
    assert faces == list(range(6))
    bound = {}
    for s in subsets:
        assert s.GetPrim().HasAPI(UsdShade.MaterialBindingAPI)
        mat, _ = UsdShade.MaterialBindingAPI(s.GetPrim()).ComputeBoundMaterial()
        bound[mat.GetPrim().GetAttribute("lantern:blenderName").Get()] = \
            sorted(s.GetIndicesAttr().Get())
    assert bound == {"Red": [0, 2, 5], "Blue": [1, 3, 4]}


def _world_points(stage, object_name):
    mesh = mesh_prim(stage, object_name)
    xf = mesh.ComputeLocalToWorldTransform(0)
    return np.array([xf.Transform(Gf.Vec3d(*p)) for p in mesh.GetPointsAttr().Get()])


def _blender_world_points(ob):
    m = np.array(ob.matrix_world)
    co = vectors(ob.data.vertices, "co").astype(np.float64)
    return co @ m[:3, :3].T + m[:3, 3]


def test_shared_mesh_is_one_prototype_referenced_twice(empty_scene):
    a = cube_object("A")
    b = cube_object("B", mesh=a.data)
    b.location = (3, 1, 0)
    b.rotation_euler = (0.3, 0.2, 1.0)
    shared_mat, override = bpy.data.materials.new("Shared"), bpy.data.materials.new("Override")
    a.data.materials.append(shared_mat)
    b.material_slots[0].link = "OBJECT"
    b.material_slots[0].material = override
    stage, report = export_current()
    protos = stage.GetPrimAtPath("/root/_prototypes")
    assert protos.IsAbstract() and len(protos.GetAllChildren()) == 1
    assert report.counts["prototypes"] == 1
    for name, ob, mat in (("A", a, "Shared"), ("B", b, "Override")):
        prim = mesh_prim(stage, name).GetPrim()
        assert prim.HasAuthoredReferences()
        np.testing.assert_allclose(_world_points(stage, name), _blender_world_points(ob),
                                   atol=1e-5)
        bound, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        assert bound.GetPrim().GetAttribute("lantern:blenderName").Get() == mat
    # The points live once, in the prototype.
    layer = stage.GetRootLayer()
    assert layer.GetAttributeAtPath("/root/A/A_mesh.points") is None
    assert layer.GetAttributeAtPath(protos.GetAllChildren()[0].GetPath().AppendProperty("points"))


def test_parented_child_composes_to_matrix_world(empty_scene):
    parent = cube_object("Parent")
    parent.location = (1, 2, 3)
    parent.rotation_euler = (0.4, -0.2, 0.9)
    parent.scale = (1, 2, 0.5)
    child = cube_object("Child")
    child.parent = parent
    child.matrix_parent_inverse = Matrix.Translation((0.5, -1, 2)) @ Matrix.Rotation(0.7, 4, "X")
    child.location = (0, 1, 0)
    bpy.context.view_layer.update()
    assert not np.allclose(np.array(child.matrix_parent_inverse), np.eye(4))
    stage, _ = export_current()
    prim = stage.GetPrimAtPath("/root/Parent/Child")
    assert prim
    usd = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0))
    np.testing.assert_allclose(usd.T, np.array(child.matrix_world), atol=1e-5)
    np.testing.assert_allclose(_world_points(stage, "Parent/Child"),
                               _blender_world_points(child), atol=1e-5)


def test_hidden_objects_are_not_written(empty_scene):
    cube_object("Shown")
    cube_object("Hidden").hide_render = True
    stage, _ = export_current()
    assert stage.GetPrimAtPath("/root/Shown")
    assert not stage.GetPrimAtPath("/root/Hidden")


def test_names_are_sanitised_unique_and_kept(empty_scene):
    cube_object("my cube")
    cube_object("my_cube")
    stage, _ = export_current()
    names = {p.GetName(): p.GetAttribute("lantern:blenderName").Get()
             for p in stage.GetPrimAtPath("/root").GetChildren() if p.IsA(UsdGeom.Xform)}
    assert names == {"my_cube": "my cube", "my_cube_1": "my_cube"}


def test_loose_geometry_is_ignored(empty_scene):
    mesh = bpy.data.meshes.new("loose")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0), (5, 5, 5), (6, 6, 6), (9, 9, 9)],
                     [(3, 4)], [(0, 1, 2)])
    ob = bpy.data.objects.new("Loose", mesh)
    bpy.context.scene.collection.objects.link(ob)
    stage, _ = export_current()
    assert list(mesh_prim(stage, "Loose").GetFaceVertexCountsAttr().Get()) == [3]
