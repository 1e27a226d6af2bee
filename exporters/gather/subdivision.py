"""A trailing Catmull-Clark Subdivision Surface modifier -> SubdivisionRecord (the cage's rules).

The cage is the mesh evaluated with that modifier switched off; the renderer refines it.
The rules are Blender's own mapping onto OpenSubdiv (which is USD's), so a USD renderer
refines the cage to the surface Blender shows.
"""
import numpy as np

from ..ir import SubdivisionRecord

# Blender's crease c (0..1) is OpenSubdiv sharpness c^2 * 10 (its subdiv converter and its
# own USD exporter); 10 is infinitely sharp in both.
MAX_SHARPNESS = 10.0

# Subsurf modifier boundary_smooth -> USD interpolateBoundary.
BOUNDARY_RULES = {"ALL": "edgeOnly", "PRESERVE_CORNERS": "edgeAndCorner"}

# Subsurf modifier uv_smooth -> USD faceVaryingLinearInterpolation.
UV_RULES = {"NONE": "all", "PRESERVE_CORNERS": "cornersOnly",
            "PRESERVE_CORNERS_AND_JUNCTIONS": "cornersPlus1",
            "PRESERVE_CORNERS_JUNCTIONS_AND_CONCAVE": "cornersPlus2",
            "PRESERVE_BOUNDARIES": "boundaries", "SMOOTH_ALL": "none"}


def crease_to_sharpness(crease):
    c = np.clip(np.asarray(crease, dtype=np.float32), 0.0, 1.0)
    return c * c * MAX_SHARPNESS


def _flag(depsgraph):
    return "show_render" if depsgraph.mode == "RENDER" else "show_viewport"


def trailing_subdivision(ob, depsgraph):
    """The object's Subdivision Surface modifier when it is Catmull-Clark and the last one
    that is on (so nothing after it needs the subdivided mesh), else None."""
    if ob.type != "MESH":
        return None
    flag = _flag(depsgraph)
    active = [m for m in ob.modifiers if getattr(m, flag)]
    if not active or active[-1].type != "SUBSURF":
        return None
    mod = active[-1]
    if mod.subdivision_type != "CATMULL_CLARK":
        return None
    return mod


def data_cage(ob, depsgraph):
    """The trailing subdivision of a mesh whose data is its cage as it stands: the
    modifier is the only one on and no shape keys mix the points. A live export reads
    such a cage from the data, switching nothing off (it runs inside a depsgraph
    update), so a viewport edit of the mesh sends the cage."""
    mod = trailing_subdivision(ob, depsgraph)
    if mod is None:
        return None
    keys = ob.data.shape_keys
    on = [m for m in ob.modifiers if getattr(m, _flag(depsgraph))]
    return mod if on == [mod] and (keys is None or len(keys.key_blocks) <= 1) else None


def subdivision_record(mod, mesh):
    """The modifier's rules over the cage `mesh` (evaluated without the modifier)."""
    edge_index, edge_sharp = np.zeros((0, 2), np.int32), np.zeros(0, np.float32)
    corner_index, corner_sharp = np.zeros(0, np.int32), np.zeros(0, np.float32)
    if mod.use_creases:
        edge_crease = _attribute(mesh, "crease_edge", len(mesh.edges))
        if edge_crease is not None:
            keep = np.flatnonzero(edge_crease > 0.0)
            verts = np.empty(len(mesh.edges) * 2, dtype=np.int32)
            mesh.edges.foreach_get("vertices", verts)
            edge_index = verts.reshape(-1, 2)[keep]
            edge_sharp = crease_to_sharpness(edge_crease[keep])
        vert_crease = _attribute(mesh, "crease_vert", len(mesh.vertices))
        if vert_crease is not None:
            corner_index = np.flatnonzero(vert_crease > 0.0).astype(np.int32)
            corner_sharp = crease_to_sharpness(vert_crease[corner_index])
    return SubdivisionRecord(
        render_level=int(mod.render_levels), viewport_level=int(mod.levels),
        crease_indices=edge_index.reshape(-1).astype(np.int32),
        crease_lengths=np.full(len(edge_index), 2, dtype=np.int32),
        crease_sharpnesses=edge_sharp.astype(np.float32),
        corner_indices=corner_index, corner_sharpnesses=corner_sharp.astype(np.float32),
        interpolate_boundary=BOUNDARY_RULES[mod.boundary_smooth],
        face_varying_linear_interpolation=UV_RULES[mod.uv_smooth],
        limit_surface=bool(mod.use_limit_surface))


def _attribute(mesh, name, size):
    attr = mesh.attributes.get(name)
    if attr is None or attr.data_type != "FLOAT" or size == 0:
        return None
    out = np.empty(size, dtype=np.float32)
    attr.data.foreach_get("value", out)
    return out
