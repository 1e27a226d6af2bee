"""MikkTSpace tangents for normal-mapped meshes, computed by Blender on the
triangulated mesh (as glTF exporters do), then carried back to the mesh's own corners.

Blender's `calc_tangents` accepts only triangles and quads, and the renderer draws
triangles, so the tangent space is computed on a triangulated copy. Each triangle
remembers its source polygon in a face layer; a corner's tangent is the one of the
triangle corner with the same polygon and vertex.
"""
import bmesh
import bpy
import numpy as np

from .node_groups import all_nodes

FACE_LAYER = "lantern_source_face"


def tangent_uv_map(materials):
    """The UV map a tangent-space Normal Map node uses ('' = the render-active map),
    or None when no material of the mesh has one: then no tangents are written."""
    for material in materials:
        tree = material.node_tree if material is not None else None
        for node in all_nodes(tree):
            if (node.bl_idname == "ShaderNodeNormalMap" and node.space == "TANGENT"
                    and node.outputs["Normal"].is_linked):
                return node.uv_map
    return None



def _loop_array(mesh, attr, width, dtype=np.float32):
    out = np.empty(len(mesh.loops) * width, dtype=dtype)
    mesh.loops.foreach_get(attr, out)
    return out.reshape(-1, width) if width > 1 else out


def mikktspace_tangents(mesh, uv_map):
    """(corners, 4) float32: tangent xyz and bitangent sign per corner of `mesh`,
    for UV map `uv_map` ('' = render-active). None when the mesh has no UV map."""
    if not mesh.uv_layers:
        return None
    uv_name = uv_map or next((l.name for l in mesh.uv_layers if l.active_render),
                             mesh.uv_layers[0].name)
    if uv_name not in mesh.uv_layers:
        return None
    bm = bmesh.new()
    try:
        bm.from_mesh(mesh)
        source = bm.faces.layers.int.new(FACE_LAYER)
        for face in bm.faces:
            face[source] = face.index
        bmesh.ops.triangulate(bm, faces=bm.faces[:], quad_method='FIXED', ngon_method='EAR_CLIP')
        triangulated = bpy.data.meshes.new("lantern_tangents")
        bm.to_mesh(triangulated)
    finally:
        bm.free()
    try:
        triangulated.calc_tangents(uvmap=uv_name)
        tangents = _loop_array(triangulated, "tangent", 3)
        signs = _loop_array(triangulated, "bitangent_sign", 1)
        vertex = _loop_array(triangulated, "vertex_index", 1, np.int64)
        faces = np.empty(len(triangulated.polygons), dtype=np.int64)
        triangulated.attributes[FACE_LAYER].data.foreach_get("value", faces)
        loop_face = np.repeat(faces, 3)
    finally:
        bpy.data.meshes.remove(triangulated)

    n_vertices = max(len(mesh.vertices), 1)
    counts = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_total", counts)
    corner_face = np.repeat(np.arange(len(counts)), counts)
    corner_vertex = _loop_array(mesh, "vertex_index", 1, np.int64)
    # Match corners by (source polygon, vertex): a sort and a binary search.
    tri_keys = loop_face * n_vertices + vertex
    order = np.argsort(tri_keys, kind="stable")
    found = order[np.searchsorted(tri_keys[order], corner_face * n_vertices + corner_vertex)]
    return np.concatenate([tangents[found], signs[found, None]], axis=1).astype(np.float32)
