"""Usd.Stage at a time code -> Scene records (no GL).

Traversal includes instance proxies (instanceable prims and references to
/root/_prototypes) and skips abstract (`class`) prims and invisible ones. Meshes are
fan-triangulated into a de-indexed triangle soup sorted by material; meshes sharing
their data (same strongest `points` spec, same materials) become one MeshData drawn
several times. A malformed mesh is skipped with a warning naming it."""
from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdShade

from . import camera as cam
from . import lights as lt
from . import skinning
from .materials import MaterialLibrary, default_material
from .scene import DrawItem, MeshData, Scene


class MeshError(ValueError):
    pass


class StageCache:
    """What a sequence reads once: built meshes (static data) and the stage's skel
    bindings. Per frame only transforms, skeleton poses, blend weights, cameras and
    lights are read again."""

    def __init__(self, stage):
        self.meshes = {}
        self.skel = skinning.SkelBindings(stage)
        self.shape_queries = {}
        self.warnings = []


def read_stage(stage: Usd.Stage, time, aspect: float, camera=None, cache=None) -> Scene:
    """`cache`: a StageCache shared by the frames of one sequence (None: one frame)."""
    cache = cache or StageCache(stage)
    scene = Scene()
    scene.meters_per_unit = float(UsdGeom.GetStageMetersPerUnit(stage))
    scene.up_axis = str(UsdGeom.GetStageUpAxis(stage))
    xcache = UsdGeom.XformCache(time)
    mats = MaterialLibrary(time, scene.warnings)
    any_light = False

    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()))
    for prim in it:
        if prim.IsAbstract():
            it.PruneChildren()
            continue
        img = UsdGeom.Imageable(prim)
        if img and img.ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            it.PruneChildren()
            continue
        if lt.is_light(prim):
            any_light = True
            rec = lt.read_light(prim, cam.gf_to_np(xcache.GetLocalToWorldTransform(prim)),
                                time, scene.warnings)
            if rec is None:
                continue
            if isinstance(rec, lt.Dome):
                if scene.dome is None:
                    scene.dome = rec
                else:
                    scene.warnings.append(f"{rec.name}: only one dome light is used; skipped")
            else:
                scene.lights.append(rec)
        elif prim.IsA(UsdGeom.Mesh):
            purpose = UsdGeom.Imageable(prim).ComputePurpose()
            if purpose in (UsdGeom.Tokens.proxy, UsdGeom.Tokens.guide):
                continue
            try:
                _add_mesh(scene, cache, prim, time, mats, xcache)
            except MeshError as exc:
                scene.warnings.append(f"{prim.GetPath()}: malformed mesh ({exc}); skipped")

    scene.warnings[:0] = cache.warnings   # the build-time ones, on every frame
    bbox = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, UsdGeom.Tokens.render],
                             useExtentsHint=True)
    rng = bbox.ComputeWorldBound(stage.GetPseudoRoot()).ComputeAlignedRange()
    if not rng.IsEmpty():
        scene.bounds = (np.array(rng.GetMin()), np.array(rng.GetMax()))

    cam_prim = cam.active_camera_prim(stage)
    if camera is not None:
        scene.camera = camera
    elif cam_prim is not None:
        scene.camera = cam.camera_from_usd(cam_prim, time, aspect, xcache)
    else:
        scene.camera = cam.default_camera(scene.bounds, scene.up_axis, aspect)

    if not any_light:
        scene.lights.append(lt.headlight(scene.camera.forward))
        scene.dome = lt.default_dome()
    return scene


# --- meshes ----------------------------------------------------------------------

def _add_mesh(scene, cache, prim, time, mats, xcache):
    binding = cache.skel.get(prim.GetPath())
    if binding is not None:
        # Skinned data is per prim (its binding), static, and built once.
        key = ("skinned", str(prim.GetPath()))
        if key not in cache.meshes:
            _, build = _mesh_key(prim, time, mats)
            mesh = build()
            mesh.key = key
            skinning.attach_skin(mesh, prim, binding, time, cache.warnings)
            cache.meshes[key] = mesh
        mesh = scene.meshes[key] = cache.meshes[key]
        skin = mesh.skin
        if skin is None:
            world = cam.gf_to_np(xcache.GetLocalToWorldTransform(prim))
            scene.draws.append(DrawItem(key, world, str(prim.GetPath())))
            return
        skel_query, sq = binding
        shapes = []
        if skin.shape_offsets is not None:
            shapes = skinning.blend_weights(skel_query, sq, cache.shape_queries, prim, time)
        if skin.has_joints:
            pose = scene.skeletons.get(skin.skel_key)
            if pose is None or (skin.method == "dqs" and not pose.dqs):
                scene.skeletons[skin.skel_key] = skinning.pose(
                    skel_query, time, skin.method == "dqs" or (pose is not None and pose.dqs))
            # UsdSkel skins into skeleton space: the mesh's own transform is ignored.
            world = cam.gf_to_np(xcache.GetLocalToWorldTransform(skel_query.GetPrim()))
        else:
            world = cam.gf_to_np(xcache.GetLocalToWorldTransform(prim))
        scene.draws.append(DrawItem(key, world, str(prim.GetPath()), shapes=shapes))
        return
    key, build = _mesh_key(prim, time, mats)
    if key not in scene.meshes:
        if key not in cache.meshes:
            mesh = build()
            if len(key) > 3:     # time-varying points: this frame only
                scene.meshes[key] = mesh
            else:
                cache.meshes[key] = mesh
        if key in cache.meshes:
            scene.meshes[key] = cache.meshes[key]
    world = cam.gf_to_np(xcache.GetLocalToWorldTransform(prim))
    scene.draws.append(DrawItem(key, world, str(prim.GetPath())))


def _face_materials(prim, mats):
    """[Material], face -> index into it (or None when one material covers all)."""
    binding = UsdShade.MaterialBindingAPI(prim)
    base = binding.ComputeBoundMaterial()[0]
    if base:
        base_mat = mats.get(base)
    else:
        dc = UsdGeom.Gprim(prim).GetDisplayColorAttr().Get()
        base_mat = default_material(dc[0] if dc else None)
    subsets = []
    for subset in binding.GetMaterialBindSubsets():
        m = UsdShade.MaterialBindingAPI(subset.GetPrim()).ComputeBoundMaterial()[0]
        if m:
            idx = subset.GetIndicesAttr().Get()
            subsets.append((mats.get(m), np.array(idx if idx is not None else [], np.int64)))
    return base_mat, subsets


def _strongest_spec(attr):
    stack = attr.GetPropertyStack(Usd.TimeCode.Default())
    if stack:
        return (stack[0].layer.identifier, str(stack[0].path))
    return ("", str(attr.GetPath()))


def _mesh_key(prim, time, mats):
    mesh = UsdGeom.Mesh(prim)
    base_mat, subsets = _face_materials(prim, mats)
    # Shared data (prototypes, references) has one strongest spec for `points`; the
    # key also holds the materials, since they change the soup's ranges and UV set.
    key = (_strongest_spec(mesh.GetPointsAttr()), base_mat.name,
           tuple((m.name, tuple(i.tolist())) for m, i in subsets))
    if isinstance(time, Usd.TimeCode) and not time.IsDefault() and \
            mesh.GetPointsAttr().ValueMightBeTimeVarying():
        key = key + (time.GetValue(),)
    return key, lambda: build_mesh(prim, time, base_mat, subsets, key)


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


def build_mesh(prim, time, base_mat, subsets, key) -> MeshData:
    mesh = UsdGeom.Mesh(prim)
    pts = mesh.GetPointsAttr().Get(time)
    counts = mesh.GetFaceVertexCountsAttr().Get(time)
    idx = mesh.GetFaceVertexIndicesAttr().Get(time)
    if pts is None or counts is None or idx is None or len(pts) == 0:
        raise MeshError("missing points, faceVertexCounts or faceVertexIndices")
    pts = np.asarray(pts, np.float64)
    counts = np.asarray(counts, np.int64)
    idx = np.asarray(idx, np.int64)
    if counts.sum() != len(idx):
        raise MeshError(f"faceVertexCounts sum {counts.sum()} != {len(idx)} indices")
    if len(idx) and (idx.min() < 0 or idx.max() >= len(pts)):
        raise MeshError(f"face vertex index out of range (max {idx.max()}, {len(pts)} points)")
    if np.any(counts < 3):
        raise MeshError("face with fewer than 3 vertices")

    n_faces = len(counts)
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
    face_of_corner = np.repeat(np.arange(n_faces), counts)
    tri_counts = counts - 2
    face_of_tri = np.repeat(np.arange(n_faces), tri_counts)
    k = np.arange(tri_counts.sum()) - np.repeat(np.cumsum(tri_counts) - tri_counts, tri_counts) + 1
    c0 = offsets[face_of_tri]
    c1, c2 = c0 + k, c0 + k + 1
    if mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded:
        c1, c2 = c2, c1  # counter-clockwise is front after this, whatever the orientation
    corners = np.stack([c0, c1, c2], axis=1).reshape(-1)      # soup corner -> face corner

    P = pts[idx[corners]]
    normals, interp = _primvar(mesh, "normals", time)
    if normals is None:
        attr = mesh.GetNormalsAttr()
        v = attr.Get(time) if attr.HasValue() else None
        if v is not None and len(v):
            normals, interp = np.asarray(v, np.float64), str(mesh.GetNormalsInterpolation())
    if normals is not None:
        N = _per_corner(normals, interp, len(pts), face_of_corner, idx, n_faces, "normals")[corners]
    else:
        N = _smooth_normals(pts, idx, corners)

    uvs, uv_interp = _pick_uv(mesh, base_mat.uv_name or next(
        (m.uv_name for m, _ in subsets if m.uv_name), None), time)
    if uvs is not None:
        UV = _per_corner(uvs, uv_interp, len(pts), face_of_corner, idx, n_faces, "uv")[corners]
    else:
        UV = np.zeros((len(corners), 2))

    # material per triangle
    materials = [base_mat]
    tri_mat = np.zeros(len(face_of_tri), np.int64)
    face_mat = np.zeros(n_faces, np.int64)
    for m, faces in subsets:
        faces = faces[(faces >= 0) & (faces < n_faces)]
        materials.append(m)
        face_mat[faces] = len(materials) - 1
    tri_mat = face_mat[face_of_tri]
    order = np.argsort(tri_mat, kind="stable")

    need_tangents = any(m.has_normal_map for m in materials)
    T = np.zeros((len(corners), 4))
    if need_tangents:
        tan, t_interp = _primvar(mesh, "tangents", time)
        if tan is not None and tan.shape[1] in (3, 4):
            tc = _per_corner(tan, t_interp, len(pts), face_of_corner, idx, n_faces, "tangents")[corners]
            T[:, :tan.shape[1]] = tc
            if tan.shape[1] == 3:
                T[:, 3] = 1.0
        elif uvs is not None:
            T = compute_tangents(P, N, UV, idx[corners])

    soup = np.concatenate([P, N, UV, T], axis=1).reshape(-1, 3, 12)[order].reshape(-1, 12)
    ranges = []
    sorted_mat = tri_mat[order]
    for mi in range(len(materials)):
        sel = np.nonzero(sorted_mat == mi)[0]
        if len(sel):
            ranges.append((mi, int(sel[0]) * 3, len(sel) * 3))
    double = bool(mesh.GetDoubleSidedAttr().Get(time))
    point_index = idx[corners].reshape(-1, 3)[order].reshape(-1).astype(np.int32)
    return MeshData(key=key, vertices=np.ascontiguousarray(soup, np.float32),
                    ranges=ranges, materials=materials, double_sided=double,
                    point_index=point_index)


def _smooth_normals(pts, idx, corners):
    tri = idx[corners].reshape(-1, 3)
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    fn = np.cross(b - a, c - a)  # area-weighted
    acc = np.zeros_like(pts)
    for j in range(3):
        np.add.at(acc, tri[:, j], fn)
    n = acc / np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-30)
    return n[tri.reshape(-1)]


def compute_tangents(P, N, UV, point_of_corner):
    """Per-triangle tangents from UVs, accumulated per point, Gram-Schmidt against
    each corner's normal; w = handedness of the UV frame."""
    p = P.reshape(-1, 3, 3)
    uv = UV.reshape(-1, 3, 2)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-20, 1.0 / np.where(det == 0, 1, det), 0.0)[:, None]
    t = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    b = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    n_pts = int(point_of_corner.max()) + 1
    tacc, bacc = np.zeros((n_pts, 3)), np.zeros((n_pts, 3))
    np.add.at(tacc, point_of_corner, np.repeat(t, 3, axis=0))
    np.add.at(bacc, point_of_corner, np.repeat(b, 3, axis=0))
    tc, bc = tacc[point_of_corner], bacc[point_of_corner]
    tc = tc - N * np.sum(N * tc, axis=1, keepdims=True)
    tc /= np.maximum(np.linalg.norm(tc, axis=1, keepdims=True), 1e-30)
    w = np.where(np.sum(np.cross(N, tc) * bc, axis=1) < 0, -1.0, 1.0)
    return np.concatenate([tc, w[:, None]], axis=1)
