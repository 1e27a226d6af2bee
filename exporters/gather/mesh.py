"""An evaluated Blender mesh -> MeshRecord."""
import numpy as np

from ..errors import require_finite
from ..ir import MeshRecord


def _get(collection, attr, dtype, width):
    out = np.empty(len(collection) * width, dtype=dtype)
    if len(collection):
        collection.foreach_get(attr, out)
    return out.reshape(-1, width) if width > 1 else out


def gather_mesh(mesh, key, name, owner=None):
    """Loose edges and vertices need nothing: only polygons are written. NaN or Inf in
    positions, normals or UVs is an ExportError naming `owner` (the object)."""
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

    material_indices = _get(mesh.polygons, "material_index", np.int32, 1)
    return MeshRecord(key=key, name=name, points=points, face_counts=counts,
                      face_indices=indices, normals=normals,
                      normals_interpolation=interpolation, uvs=uvs,
                      active_uv=active, material_indices=material_indices)
