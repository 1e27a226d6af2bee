"""An evaluated Blender mesh -> MeshRecord."""
import re

import numpy as np

from ..errors import require_finite
from ..ir import MeshRecord
from .node_groups import all_nodes

# The primvar of a mesh's render colour attribute (a Color Attribute node naming none).
RENDER_COLOR = "displayColor"
# Attribute types a network reads, as Cycles' Attribute node gives them: colours as
# they are (scene linear), vectors as xyz, a 2D vector as (x, y, 0), a float as f, f, f.
ATTRIBUTE_TYPES = {"FLOAT_COLOR": ("color", 4), "BYTE_COLOR": ("color", 4),
                   "FLOAT_VECTOR": ("vector", 3), "FLOAT2": ("vector", 2), "FLOAT": ("value", 1)}


def attribute_primvar(name: str) -> str:
    """The primvar a colour attribute is written as, and a network's attribute node reads
    (a valid USD identifier, as Tf.MakeValidIdentifier makes one)."""
    if not name:
        return RENDER_COLOR
    ident = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return "_" + ident if ident[0].isdigit() else ident


def color_attribute_names(materials) -> set:
    """The attributes the materials' networks read ('' = the render colour one), inside
    node groups too."""
    names = set()
    for material in materials:
        tree = material.node_tree if material is not None else None
        for node in all_nodes(tree):
            if node.bl_idname == "ShaderNodeVertexColor":
                names.add(node.layer_name)
            elif node.bl_idname == "ShaderNodeAttribute" and node.attribute_type == "GEOMETRY":
                names.add(node.attribute_name)
    return names


def _color_attribute(mesh, name, owner, warn):
    """(corners, 4) values of attribute `name` ('' = the render colour attribute) as a
    network reads them (ATTRIBUTE_TYPES; alpha 1 but for colours), or None with a
    warning."""
    attrs = mesh.color_attributes
    if not name:
        index = attrs.render_color_index
        attr = attrs[index] if 0 <= index < len(attrs) else None
    else:
        attr = mesh.attributes.get(name)
    if attr is None or attr.data_type not in ATTRIBUTE_TYPES or \
            attr.domain not in {"POINT", "CORNER", "FACE"}:
        if warn is not None:
            warn(f"{owner}: attribute '{name or '(render colour)'}' is not on the mesh as a "
                 f"point, corner or face colour, vector or float; its network reads black")
        return None
    field, width = ATTRIBUTE_TYPES[attr.data_type]
    raw = _get(attr.data, field, np.float32, width).reshape(len(attr.data), width)
    values = np.zeros((len(raw), 4), np.float32)
    values[:, 3] = 1.0
    if width == 1:
        values[:, :3] = raw
    else:
        values[:, :min(width, 4)] = raw[:, :4]      # a colour: rgba (rgb scene linear)
    if attr.domain == "POINT":
        values = values[_get(mesh.loops, "vertex_index", np.int32, 1)]
    elif attr.domain == "FACE":
        corners_per_face = _get(mesh.polygons, "loop_total", np.int32, 1)
        values = np.repeat(values, corners_per_face, axis=0)
    require_finite(values, owner, f"attribute '{attr.name}'")
    return np.ascontiguousarray(values)


def _get(collection, attr, dtype, width):
    out = np.empty(len(collection) * width, dtype=dtype)
    if len(collection):
        collection.foreach_get(attr, out)
    return out.reshape(-1, width) if width > 1 else out


def gather_mesh(mesh, key, name, owner=None, color_names=(), warn=None):
    """Loose edges and vertices need nothing: only polygons are written. NaN or Inf in
    positions, normals or UVs is an ExportError naming `owner` (the object).
    `color_names`: the colour attributes its materials' networks read."""
    owner = owner or f"mesh '{name}'"
    points = _get(mesh.vertices, "co", np.float32, 3)
    require_finite(points, owner, "vertex positions")
    counts = _get(mesh.polygons, "loop_total", np.int32, 1)
    indices = _get(mesh.loops, "vertex_index", np.int32, 1)
    corner_normals = _get(mesh.corner_normals, "vector", np.float32, 3)
    vertex_normals = _get(mesh.vertex_normals, "vector", np.float32, 3)

    require_finite(corner_normals, owner, "normals")
    # Vertex normals are enough (and smaller) when no corner differs from its vertex.
    if len(indices) and np.allclose(corner_normals, vertex_normals[indices], atol=1e-5):
        normals, interpolation = vertex_normals, "vertex"
    else:
        normals, interpolation = corner_normals, "faceVarying"

    uvs = {}
    for layer in mesh.uv_layers:
        uvs[layer.name] = _get(layer.uv, "vector", np.float32, 2)
        require_finite(uvs[layer.name], owner, f"UV map '{layer.name}'")
    active = next((l.name for l in mesh.uv_layers if l.active_render), None)

    colors = {}
    for color_name in sorted(color_names):
        if color_name in uvs:       # a UV map: its texCoord2f primvar is read as (u, v, 0)
            continue
        values = _color_attribute(mesh, color_name, owner, warn)
        if values is not None:
            colors[attribute_primvar(color_name)] = values

    material_indices = _get(mesh.polygons, "material_index", np.int32, 1)
    return MeshRecord(key=key, name=name, points=points, face_counts=counts,
                      face_indices=indices, normals=normals,
                      normals_interpolation=interpolation, uvs=uvs,
                      active_uv=active, material_indices=material_indices, colors=colors)
