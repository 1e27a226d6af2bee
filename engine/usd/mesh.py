"""UsdGeom.Mesh -> MeshData: indexed triangles sorted by material.

Faces are triangulated by core.triangulate (earcut for anything but triangles and convex
quads: never a fan of a concave polygon), every attribute is gathered per triangle corner exactly as authored
(vertex, faceVarying, uniform or constant), and corners that are the same face corner
(or the same point, when every attribute is per point) become one vertex: indexing
changes how many vertices are shaded, never their values. A malformed mesh raises
MeshError naming the defect."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from ...core.triangulate import triangulate
from ...core.pattern_nodes import attribute_opacity
from ..scene import STREAM_WIDTHS, MeshData, PatchData
from ..vertex_attributes import compute_tangents, generated_coordinates, index_corners, smooth_normals
from .subdivision import RefinedCage, limit_surface, skinned_cage_unrefined, subdivision_level
from .validate import check_items


class MeshError(ValueError):
    pass


@dataclass
class Surface:
    """What build_mesh reads of a gprim that is not a Mesh: the faces an implicit
    surface (shapes.py) or an oriented ribbon (curves.py) makes, with their normals
    per point. `point_source` and `face_source` say which of the prim's own vertices
    and uniform elements (a curve) each point and face comes from, so the prim's
    vertex and uniform primvars carry over; without them only constant primvars do."""
    points: np.ndarray
    counts: np.ndarray
    indices: np.ndarray
    normals: np.ndarray
    point_source: np.ndarray | None = None
    face_source: np.ndarray | None = None

    def primvar(self, prim, name, time):
        """(values, interpolation) of the prim's primvar in this surface's terms, or
        (None, None) where it has none that carries over."""
        values, interp = _primvar(prim, name, time)
        if values is None or interp == "constant":
            return values, interp
        if interp in ("vertex", "varying") and self.point_source is not None and \
                len(values) > self.point_source.max(initial=0):
            return values[self.point_source], "vertex"
        if interp == "uniform" and self.face_source is not None and \
                len(values) > self.face_source.max(initial=0):
            return values[self.face_source], "uniform"
        return None, None


def _primvar(mesh, name, time):
    pv = UsdGeom.PrimvarsAPI(mesh).GetPrimvar(name)
    if pv and pv.HasValue():
        v = pv.ComputeFlattened(time)
        if v is not None:
            return np.asarray(v, dtype=np.float64), str(pv.GetInterpolation())
    return None, None


def _per_corner(values, interp, n_points, face_of_corner, vidx, n_faces, what):
    n = len(values)
    if interp in ("vertex", "varying"):
        if n < n_points:
            raise MeshError(f"{what} has {n} values for {n_points} points")
        return values[vidx]
    if interp == "faceVarying":
        if n != len(vidx):
            raise MeshError(f"{what} has {n} faceVarying values for {len(vidx)} corners")
        return values
    if interp == "uniform":
        if n < n_faces:
            raise MeshError(f"{what} has {n} uniform values for {n_faces} faces")
        return values[face_of_corner]
    if interp == "constant" and n >= 1:
        return np.repeat(values[:1], len(vidx), axis=0)
    raise MeshError(f"{what} has unsupported interpolation {interp}")


def _per_point(interp) -> bool:
    return interp in ("vertex", "varying", "constant")


def _pick_uv(mesh, wanted, time):
    names = [wanted] if wanted else []
    names.append("st")
    for n in names:
        v, interp = _primvar(mesh, n, time)
        if v is not None and v.ndim == 2 and v.shape[1] == 2:
            return v, interp
    for pv in UsdGeom.PrimvarsAPI(mesh).GetPrimvars():
        if pv.GetTypeName() == Sdf.ValueTypeNames.TexCoord2fArray:
            v = pv.ComputeFlattened(time)
            if v is not None and len(v):
                return np.asarray(v, np.float64), str(pv.GetInterpolation())
    return None, None


def _finite(values, what):
    """MeshError naming how many values are not finite in float32 (validate.py; the
    prim is then skipped: a non-finite vertex would smear NaN over every pixel it
    touches)."""
    check_items(values, what, MeshError)


def build_mesh(prim, time, materials, subsets, key, warnings=None, tessellate=False,
               surface: Surface | None = None) -> MeshData:
    """materials: [Material] (the prim's own first, then one per subset); subsets:
    [(index into materials, face indices)]. Zero-length normals are replaced by the
    surface's own (with a warning in `warnings`). `tessellate`: a subdivision surface
    becomes patches for the GPU (MeshData.patches) where its materials need no more
    than positions, normals and UVs, else it is refined here. `surface`: the faces of
    a gprim that is not a Mesh (its primvars are read through it)."""
    mesh = UsdGeom.Mesh(prim)
    if surface is not None:
        pts, counts, idx = surface.points, surface.counts, surface.indices
    else:
        pts = mesh.GetPointsAttr().Get(time)
        counts = mesh.GetFaceVertexCountsAttr().Get(time)
        idx = mesh.GetFaceVertexIndicesAttr().Get(time)
    if pts is None or counts is None or idx is None or len(pts) == 0:
        raise MeshError("missing points, faceVertexCounts or faceVertexIndices")
    pts = np.asarray(pts, np.float64)
    counts = np.asarray(counts, np.int64)
    if not len(counts):
        raise MeshError(f"no faces ({len(pts)} points only)")
    idx = np.asarray(idx, np.int64)
    if counts.sum() != len(idx):
        raise MeshError(f"faceVertexCounts sum {counts.sum()} != {len(idx)} indices")
    if len(idx) and (idx.min() < 0 or idx.max() >= len(pts)):
        raise MeshError(f"face vertex index out of range (max {idx.max()}, {len(pts)} points)")
    if np.any(counts < 3):
        raise MeshError("face with fewer than 3 vertices")
    _finite(pts[np.unique(idx)], "points used by faces")
    levels, refined = (0 if surface else subdivision_level(prim, warnings)), None
    patches = tessellate and limit_surface(prim) and not any(
        m.needs_tangents or m.reads_generated or m.color_attribute or m.udim_tiles
        for m in materials)
    if levels and skinned_cage_unrefined(prim, warnings, tessellate, patches):
        levels = 0
    if levels:
        # Normals and tangents are the refined surface's own (USD ignores authored ones
        # on a subdivision surface); UVs and subsets follow the refined faces.
        refined = RefinedCage(mesh, pts, counts, idx, levels, time, patches=patches)
        if refined.patches is not None:
            return _patch_mesh(prim, mesh, refined, levels, time, materials, subsets, key,
                               (counts, idx, pts))
        cage_counts, cage_idx, cage_points = counts, idx, len(pts)
        pts, counts, idx = refined.points, refined.counts, refined.indices
    n_faces = len(counts)
    face_of_corner = np.repeat(np.arange(n_faces), counts)
    tri, face_of_tri = triangulate(pts if surface else _topology_points(mesh, pts), counts, idx)
    if not surface and mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded:
        tri = tri[:, [0, 2, 1]]  # counter-clockwise is front after this, whatever the orientation
    corners = tri.reshape(-1)      # triangle corner -> face corner

    P = pts[idx[corners]]
    per_point = True
    if surface:
        normals, interp = surface.normals, "vertex"
    else:
        normals, interp = _primvar(mesh, "normals", time) if refined is None else (None, None)
    if normals is None and refined is None:
        attr = mesh.GetNormalsAttr()
        v = attr.Get(time) if attr.HasValue() else None
        if v is not None and len(v):
            normals, interp = np.asarray(v, np.float64), str(mesh.GetNormalsInterpolation())
    if normals is not None:
        N = _per_corner(normals, interp, len(pts), face_of_corner, idx, n_faces, "normals")[corners]
        _finite(N, "normals (per corner)")
        per_point &= _per_point(interp)
        zero = np.linalg.norm(N, axis=1) == 0
        if zero.any():
            N[zero] = smooth_normals(pts, idx, corners)[zero]
            if warnings is not None:
                warnings.append(f"{prim.GetPath()}: {int(zero.sum())} zero-length normals "
                                f"(per corner); the surface's own used there")
    else:
        N = smooth_normals(pts, idx, corners)

    uv_name = next((m.uv_name for m in materials if m.uv_name), None)
    uvs, uv_interp = _pick_uv(mesh, uv_name, time) if not surface else (None, None)
    if uvs is not None and refined is not None:
        cage_uv = _per_corner(uvs, uv_interp, cage_points,
                              np.repeat(np.arange(len(cage_counts)), cage_counts), cage_idx,
                              len(cage_counts), "uv")
        UV = refined.face_varying(cage_uv)[corners]
        _finite(UV, "texture coordinates (per corner)")
        per_point = False
    elif uvs is not None:
        UV = _per_corner(uvs, uv_interp, len(pts), face_of_corner, idx, n_faces, "uv")[corners]
        _finite(UV, "texture coordinates (per corner)")
        per_point &= _per_point(uv_interp)
    else:
        UV = np.zeros((len(corners), 2))

    tri_mat = np.zeros(len(face_of_tri), np.int64)
    face_mat = np.zeros(n_faces, np.int64)
    for mi, faces in subsets:
        if refined is not None:
            faces = refined.faces(faces)
        faces = faces[(faces >= 0) & (faces < n_faces)]
        face_mat[faces] = mi
    tri_mat = face_mat[face_of_tri]
    materials, tri_mat = split_udim_tiles(materials, tri_mat, UV)
    order = np.argsort(tri_mat, kind="stable")

    T = np.zeros((len(corners), 4))
    if any(m.needs_tangents for m in materials):
        tan, t_interp = _primvar(mesh, "tangents", time) if refined is None and not surface \
            else (None, None)
        if tan is not None and tan.shape[1] in (3, 4):
            tc = _per_corner(tan, t_interp, len(pts), face_of_corner, idx, n_faces, "tangents")[corners]
            _finite(tc, "tangents (per corner)")
            T[:, :tan.shape[1]] = tc
            if tan.shape[1] == 3:
                T[:, 3] = 1.0
            per_point &= _per_point(t_interp)
        elif uvs is not None:
            T = compute_tangents(P, N, UV, idx[corners])   # a function of point and normal

    # Streams bound networks read (MeshData.streams): more columns each (STREAM_WIDTHS),
    # split off below, so that they follow the vertices' order and sharing.
    # One attribute: on every triangle (per point where the primvar is). Several (the
    # mesh's materials read different ones; one each): each on its material's
    # triangles, and a point's value then depends on the face, so per corner.
    attributes = {mi: m.color_attribute for mi, m in enumerate(materials) if m.color_attribute}
    names = sorted(set(attributes.values()))
    columns, streams = [P, N, UV, T], []
    if any(m.reads_generated for m in materials):
        streams.append("generated")
        rest = pts if surface else _topology_points(mesh, pts)
        columns.append(generated_coordinates(rest)[idx[corners]])
    if attributes:
        streams.append("colors")
        C = np.zeros((len(corners), 4))
        per_point &= len(names) == 1
        for name in names:
            mine = np.ones(len(corners), bool) if len(names) == 1 else np.repeat(
                np.isin(tri_mat, [mi for mi, n in attributes.items() if n == name]), 3)
            rgba, interp = _attribute(mesh, name, time, surface) if refined is None else (None, None)
            if rgba is None:
                if warnings is not None:
                    warnings.append(f"{prim.GetPath()}: no colour primvar {name!r} for its "
                                    f"material's network; it reads black")
                continue
            C[mine] = _per_corner(rgba, interp, len(pts), face_of_corner, idx, n_faces,
                                  name)[corners][mine]
            _finite(C[mine], f"{name} (per corner)")
            per_point &= _per_point(interp)
        columns.append(C)
    width = sum(c.shape[1] for c in columns)
    soup = np.concatenate(columns, axis=1).reshape(-1, 3, width)[order].reshape(-1, width)
    ranges = []
    sorted_mat = tri_mat[order]
    for mi in range(len(materials)):
        sel = np.nonzero(sorted_mat == mi)[0]
        if len(sel):
            ranges.append((mi, int(sel[0]) * 3, len(sel) * 3))
    sorted_corners = corners.reshape(-1, 3)[order].reshape(-1)
    point_of_corner = idx[sorted_corners]
    vertices, indices, first = index_corners(soup, point_of_corner if per_point else sorted_corners,
                                             len(pts) if per_point else len(idx))
    double, culling = _sidedness(prim, mesh, time)
    extra, at = {}, 12
    for name in streams:
        extra[name] = np.ascontiguousarray(vertices[:, at:at + STREAM_WIDTHS[name]])
        at += STREAM_WIDTHS[name]
    return MeshData(key=key, vertices=np.ascontiguousarray(vertices[:, :12]), indices=indices,
                    ranges=ranges, streams=extra,
                    materials=[m.name for m in materials], double_sided=double,
                    backface_culling=culling,
                    point_of_vertex=point_of_corner[first].astype(np.int32),
                    surface_normals=normals is None)


def _attribute(mesh, name, time, surface=None):
    """(values (n, 4), interpolation) of the primvar an attribute node reads, or (None,
    None): a colour or vector as xyz, a 2D one (a UV map read by an Attribute node) as
    (x, y, 0), as Cycles reads it; alpha from its opacity primvar, else 1."""
    read = surface.primvar if surface else _primvar
    values, interp = read(mesh, name, time)
    if values is None or values.ndim != 2 or values.shape[1] < 2:
        return None, None
    rgba = np.zeros((len(values), 4))
    rgba[:, :min(values.shape[1], 3)] = values[:, :3]
    alpha, a_interp = read(mesh, attribute_opacity(name), time)
    ok = alpha is not None and alpha.ndim == 1 and a_interp == interp and len(alpha) == len(values)
    rgba[:, 3] = alpha if ok else 1.0
    return rgba, interp


def split_udim_tiles(materials, tri_mat, uv):
    """([Material], triangle -> material index) with the triangles of a UDIM material
    whose UV centre lies in another of its tiles given that tile's record
    (Material.for_tile), as Cycles picks a tile by the UV's integer part. Triangles in
    the first tile, or in none of the image's tiles, keep the material's own record
    (the first tile's image)."""
    if not any(m.udim_tiles for m in materials):
        return materials, tri_mat
    materials, tri_mat = list(materials), tri_mat.copy()
    column, row = np.floor(uv.reshape(-1, 3, 2).mean(axis=1)).T
    inside = (column >= 0) & (column < 10) & (row >= 0)     # UDIM's ten tiles a row
    tile = np.where(inside, 1001 + column + 10 * row, 0).astype(np.int64)
    for mi, material in enumerate(list(materials)):
        mine = tri_mat == mi
        for t in material.udim_tiles[1:]:
            sel = mine & (tile == t)
            if sel.any():
                materials.append(material.for_tile(t))
                tri_mat[sel] = len(materials) - 1
    return materials, tri_mat


MAX_TESSELLATED_VERTICES = 1 << 22


def _stencil_rows(stencils, rows):
    """CSR stencils (engine/bezier_patches.py patch_stencils) with their rows reordered:
    new row i is old row rows[i]."""
    indptr, indices, weights = stencils
    starts = indptr[rows]
    counts = indptr[rows + 1] - starts
    new_ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    take = np.repeat(starts - new_ptr[:-1], counts) + np.arange(new_ptr[-1])
    return new_ptr, indices[take], weights[take]


def _sidedness(prim, mesh, time):
    """(double-sided, back faces culled as lantern:backfaceCulling asks)."""
    double = bool(mesh.GetDoubleSidedAttr().Get(time))
    marker = prim.GetAttribute("lantern:backfaceCulling")
    culling = bool(marker.Get(time)) if marker and marker.HasValue() else False
    return double, culling and not double


def _patch_mesh(prim, mesh, refined, render_level, time, materials, subsets, key, cage):
    """MeshData of a subdivision surface the GPU tessellates: its patches sorted by
    material, their corner UVs, and a cap of one level finer than the render level
    (within a memory budget)."""
    counts, idx, cage_points = cage
    n_points = len(cage_points)
    control = refined.patches.reshape(-1, 4, 4, 3)
    n = len(control)
    uv_name = next((m.uv_name for m in materials if m.uv_name), None)
    uvs, uv_interp = _pick_uv(mesh, uv_name, time)
    if uvs is not None:
        cage_uv = _per_corner(uvs, uv_interp, n_points, np.repeat(np.arange(len(counts)), counts),
                              idx, len(counts), "uv")
        uv = refined.face_varying_patches(cage_uv).reshape(n, 4, 4, 2)
        _finite(uv, "texture coordinates (per corner)")
    else:
        uv = np.zeros((n, 4, 4, 2))
    stencils = refined.stencils
    if mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded:
        control = control.transpose(0, 2, 1, 3)     # u and v swapped: the other side is front
        uv = uv.transpose(0, 2, 1, 3)
        if stencils is not None:
            stencils = _stencil_rows(stencils, np.arange(n * 16).reshape(n, 4, 4)
                                     .transpose(0, 2, 1).reshape(-1))
    face_mat = np.zeros(n, np.int64)
    for mi, faces in subsets:
        faces = refined.faces(faces)
        face_mat[faces[(faces >= 0) & (faces < n)]] = mi
    order = np.argsort(face_mat, kind="stable")
    ranges = []
    for mi in range(len(materials)):
        sel = np.flatnonzero(face_mat[order] == mi)
        if len(sel):
            ranges.append((mi, int(sel[0]), len(sel)))
    control = np.ascontiguousarray(control[order].reshape(n, 16, 3), np.float32)
    points = control.reshape(-1, 3).astype(np.float64)
    vertices, point_of_vertex = np.zeros((0, 12), np.float32), None
    if stencils is not None:
        # Skinned: the cage's points are the vertices the skinning pass deforms, and
        # the patches are made from them again after each pose.
        stencils = _stencil_rows(stencils, (order[:, None] * 16 + np.arange(16)).reshape(-1))
        vertices = np.zeros((n_points, 12), np.float32)
        vertices[:, :3] = cage_points
        point_of_vertex = np.arange(n_points, dtype=np.int32)
        points = cage_points      # the patches lie inside the hull of the cage
    double, culling = _sidedness(prim, mesh, time)
    # The GPU's place for the triangles is sized for the cap: at most
    # MAX_TESSELLATED_VERTICES corners (192 MiB) a mesh, whatever its render level.
    budget = int(np.sqrt(MAX_TESSELLATED_VERTICES / (6 * n)))
    cap = int(np.clip(min(2 ** (render_level - refined.levels + 1), budget), 1, 64))
    return MeshData(key=key, vertices=vertices, point_of_vertex=point_of_vertex,
                    indices=np.zeros(0, np.uint32), ranges=[],
                    materials=[m.name for m in materials], double_sided=double,
                    backface_culling=culling,
                    # A Bezier patch lies inside the hull of its control points.
                    bounds=(points.min(axis=0), points.max(axis=0)),
                    patches=PatchData(control, np.ascontiguousarray(uv[order].reshape(n, 16, 2),
                                                                    np.float32),
                                      ranges, refined.levels, cap, stencils))


def _topology_points(mesh, pts):
    """The points a mesh is triangulated against. Topology is static data: cutting each
    frame's quads by that frame's shape would let triangles flip as a mesh deforms, and
    a skinned mesh and its baked twin would cut differently. The authored default
    (the rest shape) serves, else the earliest sample."""
    attr = mesh.GetPointsAttr()
    for when in (Usd.TimeCode.Default(), Usd.TimeCode.EarliestTime()):
        ref = attr.Get(when)
        if ref is not None and len(ref) == len(pts):
            return np.asarray(ref, np.float64)
    return pts
