"""MikkTSpace tangents: written as primvars only for normal-mapped meshes, computed on
the triangulated mesh, and valid on n-gons too."""
import bpy
import numpy as np
from pxr import UsdGeom

from lantern.exporters import stage_from_depsgraph


def _normal_mapped(material_name="Bumpy"):
    material = bpy.data.materials.new(material_name)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    image = bpy.data.images.new("flat_normal", 4, 4)
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    normal_map = nodes.new("ShaderNodeNormalMap")
    links.new(texture.outputs["Color"], normal_map.inputs["Color"])
    links.new(normal_map.outputs["Normal"], nodes["Principled BSDF"].inputs["Normal"])
    return material


def _mesh_prim(stage, object_name):
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.Mesh) and prim.GetParent().GetAttribute("lantern:blenderName").Get() == object_name:
            return prim
    raise AssertionError(f"no mesh for {object_name}")


def _tangents(stage, object_name):
    primvar = UsdGeom.PrimvarsAPI(_mesh_prim(stage, object_name)).GetPrimvar("tangents")
    if not primvar:
        return None
    assert primvar.GetInterpolation() == UsdGeom.Tokens.faceVarying
    return np.array(primvar.Get(), dtype=np.float64)


def test_plane_tangent_follows_u_and_mirrored_uvs_flip_the_sign(empty_scene):
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.object
    plane.name = "Plane"
    plane.data.materials.append(_normal_mapped())
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(3, 0, 0))
    mirrored = bpy.context.object
    mirrored.name = "Mirrored"
    mirrored.data.materials.append(_normal_mapped("Bumpy2"))
    uv = mirrored.data.uv_layers.active.data
    for loop in uv:
        loop.uv = (1.0 - loop.uv[0], loop.uv[1])  # mirror U

    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    t = _tangents(stage, "Plane")
    assert t.shape == (4, 4)
    assert np.allclose(t[:, :3], [1, 0, 0], atol=1e-6) and np.all(t[:, 3] == 1.0)
    # Mirrored U: the tangent turns to -X, and the bitangent (+V = +Y) = sign · N × T
    # = sign · (-Y), so the sign is -1.
    m = _tangents(stage, "Mirrored")
    assert np.allclose(m[:, :3], [-1, 0, 0], atol=1e-6), m
    assert np.all(m[:, 3] == -1.0), m


def test_ngon_mesh_gets_unit_tangents_orthogonal_to_its_normals(empty_scene):
    bpy.ops.mesh.primitive_cylinder_add(vertices=8)  # 8-gon caps: calc_tangents alone refuses
    cylinder = bpy.context.object
    cylinder.name = "Cylinder"
    cylinder.data.materials.append(_normal_mapped())
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    mesh = UsdGeom.Mesh(_mesh_prim(stage, "Cylinder"))
    t = _tangents(stage, "Cylinder")
    corners = len(mesh.GetFaceVertexIndicesAttr().Get())
    assert t.shape == (corners, 4)
    assert np.allclose(np.linalg.norm(t[:, :3], axis=1), 1.0, atol=1e-4)
    assert set(np.unique(t[:, 3])) <= {-1.0, 1.0}
    normals = np.array(mesh.GetNormalsAttr().Get(), dtype=np.float64)
    if mesh.GetNormalsInterpolation() == UsdGeom.Tokens.vertex:
        normals = normals[np.array(mesh.GetFaceVertexIndicesAttr().Get())]
    assert np.abs(np.sum(t[:, :3] * normals, axis=1)).max() < 1e-3


def test_no_tangents_without_a_normal_map(empty_scene):
    bpy.ops.mesh.primitive_cube_add()
    bpy.context.object.name = "Cube"
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert _tangents(stage, "Cube") is None
