"""UsdSkel bindings, poses and blend-shape weights -> SkinData and SkelPose records
(the convention is in engine/skin.py).

Weights are used as authored (UsdSkel does not renormalise them). Up to 8
influences per point travel as vertex attributes; a mesh with more reads all of
them from a per-point influence texture instead, so no influence is ever dropped.
Static data (influences, blend-shape offsets, bind transforms) is read once per
binding; per frame only poses and blend-shape weights are."""
from __future__ import annotations

import numpy as np
from pxr import Usd, UsdSkel, Vt

from ..scene import SkelPose, SkinData
from ..skin import MAX_ATTRIBUTE_INFLUENCES, influence_texels
from .paths import under
from .validate import NOT_FINITE, check_items, unfit_items


class BindingError(ValueError):
    pass


# --- reading ---------------------------------------------------------------------

class SkelBindings:
    """mesh path -> (SkeletonQuery, SkinningQuery) for every SkelRoot of a stage,
    each root populated once and again only when something under it changes."""

    def __init__(self, stage):
        self.stage = stage
        self.by_mesh = {}
        self.roots = {}          # SkelRoot path -> its UsdSkel.Cache
        self.refresh("/")

    def refresh(self, path: str):
        """Re-reads the bindings of every SkelRoot under `path` (and of the SkelRoot
        above it, if any)."""
        root = self.root_of(path) or path
        pred = Usd.TraverseInstanceProxies()
        for old in [r for r in self.roots if under(r, root)]:
            del self.roots[old]
        for mesh in [m for m in self.by_mesh if under(m, root)]:
            del self.by_mesh[mesh]
        prim = self.stage.GetPrimAtPath(root)
        if not prim:
            return
        for prim in Usd.PrimRange(prim, pred):
            if not prim.IsA(UsdSkel.Root):
                continue
            cache = UsdSkel.Cache()
            skel_root = UsdSkel.Root(prim)
            cache.Populate(skel_root, pred)
            self.roots[str(prim.GetPath())] = cache
            for binding in cache.ComputeSkelBindings(skel_root, pred):
                skel_query = cache.GetSkelQuery(binding.GetSkeleton())
                if not skel_query:
                    continue
                for sq in binding.GetSkinningTargets():
                    self.by_mesh[str(sq.GetPrim().GetPath())] = (skel_query, sq)

    def root_of(self, path: str):
        """The path of the SkelRoot at or above `path`, or None."""
        prim = self.stage.GetPrimAtPath(path)
        while prim and not prim.IsPseudoRoot():
            if prim.IsA(UsdSkel.Root):
                return str(prim.GetPath())
            prim = prim.GetParent()
        return None

    def get(self, path):
        return self.by_mesh.get(str(path))


def skel_key(skel_query) -> str:
    return str(skel_query.GetPrim().GetPath())


def _pad_influences(idx, wts):
    """(n, k) -> (n, 4·ceil(k/4)): whole groups of four for attributes or texels."""
    pad = -idx.shape[1] % 4
    if pad:
        idx = np.pad(idx, ((0, 0), (0, pad)))
        wts = np.pad(wts, ((0, 0), (0, pad)))
    return idx.astype(np.int32), wts.astype(np.float32)


def _joint_influences(skel_query, sq, n_points, time, path, warnings):
    """Per point (n_points, 4|8) skeleton-order joint indices and weights."""
    n_skel = len(skel_query.GetJointOrder())
    k = int(sq.GetNumInfluencesPerComponent())
    ind_pv, wt_pv = sq.GetJointIndicesPrimvar(), sq.GetJointWeightsPrimvar()
    ind = ind_pv.ComputeFlattened(time) if ind_pv else None
    wts = wt_pv.ComputeFlattened(time) if wt_pv else None
    if ind is None or wts is None:
        raise BindingError("jointIndices or jointWeights has no value")
    ind, wts = np.asarray(ind, np.int64), np.asarray(wts, np.float64)
    check_items(wts, "jointWeights", BindingError)
    if len(ind) != len(wts):
        raise BindingError(f"{len(ind)} jointIndices but {len(wts)} jointWeights")
    if k < 1 or len(ind) % k:
        raise BindingError(f"{len(ind)} influences is not a multiple of elementSize {k}")
    if str(sq.GetInterpolation()) == "constant":
        if len(ind) != k:
            raise BindingError(f"constant influences have {len(ind)} values, elementSize {k}")
        ind, wts = np.tile(ind, n_points), np.tile(wts, n_points)
    elif len(ind) != n_points * k:
        raise BindingError(f"{len(ind)} influences for {n_points} points x elementSize {k}")
    ind, wts = ind.reshape(n_points, k), wts.reshape(n_points, k)

    mesh_joints = sq.GetJointOrder()
    n_mesh = len(mesh_joints) if mesh_joints else n_skel
    if len(ind) and (ind.min() < 0 or ind.max() >= n_mesh):
        raise BindingError(f"joint index out of range (indices {ind.min()}..{ind.max()}, "
                           f"{n_mesh} joints)")
    mapper = sq.GetJointMapper()
    if mapper and not mapper.IsNull() and not mapper.IsIdentity():
        # The mapper carries skeleton-order data to the mesh's order; carrying the
        # skeleton indices themselves gives mesh joint -> skeleton joint.
        to_skel = np.asarray(mapper.Remap(Vt.IntArray(list(range(n_skel))), Vt.IntArray(),
                                          1, n_skel), np.int64)
        ind = to_skel[ind]          # joints the skeleton lacks -> the identity joint
    ind = np.where(wts != 0, ind, 0)
    return _pad_influences(ind, wts)


def _sub_shape_normals(bsq, offsets):
    """Normal offsets per sub-shape, in BlendShapeQuery's sub-shape order (per blend
    shape: its inbetweens, the null shape at 0 and the primary at 1, sorted by
    weight). None when that order does not
    reproduce the query's own point offsets."""
    out = []
    for b in range(bsq.GetNumBlendShapes()):
        shape = bsq.GetBlendShape(b)
        entries = [(0.0, [], []),
                   (1.0, shape.GetOffsetsAttr().Get(), shape.GetNormalOffsetsAttr().Get())]
        for ib in shape.GetInbetweens():
            entries.append((ib.GetWeight() or 0.0, ib.GetOffsets(), ib.GetNormalOffsets()))
        entries.sort(key=lambda e: e[0])
        out += [(np.asarray(p if p is not None else [], np.float64).reshape(-1, 3),
                 np.asarray(n if n is not None else [], np.float64).reshape(-1, 3))
                for _, p, n in entries]
    if len(out) != len(offsets):
        return None
    for (p, _), ref in zip(out, offsets):
        if p.shape != ref.shape or (len(p) and not np.allclose(p, ref)):
            return None
    return [n for _, n in out]


def _blend_shapes(sq, n_points, skin, path, warnings):
    bsq = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(sq.GetPrim()))
    if not bsq or bsq.GetNumSubShapes() == 0:
        return None
    indices = [np.asarray(i, np.int64) for i in bsq.ComputeBlendShapePointIndices()]
    offsets = [np.asarray(o, np.float64).reshape(-1, 3) for o in bsq.ComputeSubShapePointOffsets()]
    normals = _sub_shape_normals(bsq, offsets)
    # sub-shape -> blend shape, from the query's own weights for each shape at 1
    sub_owner = []
    for b in range(bsq.GetNumBlendShapes()):
        sub_owner += [b] * (len(bsq.GetBlendShape(b).GetInbetweens()) + 2)
    if len(sub_owner) != len(offsets):
        sub_owner = None
    blocks, data, maxes = [], [], []

    def dense(values, b):
        if not len(values):
            return None
        pts = indices[b] if sub_owner is not None and len(indices[b]) else None
        full = np.zeros((n_points, 3))
        if pts is None:
            if len(values) != n_points:
                raise BindingError(f"blend shape has {len(values)} offsets for {n_points} points")
            full[:] = values
        else:
            if len(values) != len(pts) or pts.min() < 0 or pts.max() >= n_points:
                raise BindingError("blend shape offsets do not match its pointIndices")
            full[pts] = values
        if not np.any(full):
            return None
        data.append(full)
        return len(data) - 1

    for s, off in enumerate(offsets):
        b = sub_owner[s] if sub_owner is not None else 0
        if sub_owner is None and len(off) != n_points:
            raise BindingError("cannot place sparse blend-shape offsets")
        pb = dense(off, b)
        nb = dense(normals[s], b) if normals is not None and len(normals[s]) else None
        blocks.append((-1 if pb is None else pb, -1 if nb is None else nb))
        maxes.append(float(np.linalg.norm(off, axis=1).max()) if len(off) else 0.0)
    if not data:
        return None
    skin.shape_offsets = np.ascontiguousarray(np.concatenate(data), np.float32)
    skin.shape_blocks = blocks
    skin.shape_max = np.array(maxes)
    return bsq


def check_unbound(prim, warnings):
    """A mesh UsdSkel did not bind although it names a skeleton: say why."""
    rel = prim.GetRelationship("skel:skeleton")
    for target in (rel.GetTargets() if rel else []):
        p = prim.GetStage().GetPrimAtPath(target)
        what = "does not exist" if not p else (
            f"is a {p.GetTypeName() or 'typeless prim'}, not a Skeleton"
            if not p.IsA(UsdSkel.Skeleton) else "is not under the mesh's SkelRoot")
        warnings.append(f"{prim.GetPath()}: its skel:skeleton {target} {what}; "
                        f"drawn unskinned")


def check_skeleton(skel_query):
    """BindingError naming the Skeleton when it cannot skin: no joints, bind
    transforms that do not match the joints, or are singular or not finite."""
    skel = skel_query.GetSkeleton()
    where = str(skel.GetPrim().GetPath())
    joints = skel_query.GetJointOrder()
    if not len(joints):
        raise BindingError(f"Skeleton {where} has no joints")
    bind = skel.GetBindTransformsAttr().Get()
    n_bind = 0 if bind is None else len(bind)
    if n_bind != len(joints):
        raise BindingError(f"Skeleton {where} has {n_bind} bindTransforms for "
                           f"{len(joints)} joints")
    m = np.array(bind, np.float64).reshape(-1, 4, 4)
    if unfit_items(m).any():
        raise BindingError(f"Skeleton {where}: bindTransforms are {NOT_FINITE}")
    det = np.linalg.det(m[:, :3, :3])
    scale = np.abs(m[:, :3, :3]).max(axis=(1, 2))
    singular = np.abs(det) <= 1e-12 * np.maximum(scale, 1e-300) ** 3
    if singular.any():
        raise BindingError(f"Skeleton {where}: the bind transform of joint "
                           f"{joints[int(np.argmax(singular))]} is singular")


def skeleton_warnings(skel_query) -> list:
    """What is odd about a Skeleton and its SkelAnimation but leaves it usable: rest
    transforms or animation channels whose counts do not match the joints (UsdSkel
    then ignores them: the skeleton keeps its rest or bind pose)."""
    out = []
    skel = skel_query.GetSkeleton()
    n = len(skel_query.GetJointOrder())
    rest = skel.GetRestTransformsAttr().Get()
    if rest is not None and len(rest) != n:
        out.append(f"{skel.GetPrim().GetPath()}: {len(rest)} restTransforms for {n} joints; "
                   f"they are ignored")
    anim_query = skel_query.GetAnimQuery()
    if anim_query:
        anim = UsdSkel.Animation(anim_query.GetPrim())
        n_anim = len(anim.GetJointsAttr().Get() or [])
        for name, attr in (("translations", anim.GetTranslationsAttr()),
                           ("rotations", anim.GetRotationsAttr()),
                           ("scales", anim.GetScalesAttr())):
            value = attr.Get(Usd.TimeCode.EarliestTime()) if attr.HasValue() else None
            if value is not None and len(value) != n_anim:
                out.append(f"{anim.GetPrim().GetPath()}: {len(value)} {name} for {n_anim} "
                           f"joints; the animation is ignored")
    return out


def attach_skin(mesh_data, prim, binding, time, warnings, points=None) -> bool:
    """Adds a SkinData (per vertex of the MeshData) to a freshly built MeshData. A
    malformed binding leaves the mesh unskinned with a warning naming it and the
    reason; returns whether skinned. `points`: the points of faces the engine made for
    a gprim that has none (an implicit surface, which UsdSkel deforms rigidly: constant
    influences on every point are that rigid transform, both LBS and DQS)."""
    skel_query, sq = binding
    path = str(prim.GetPath())
    if points is None:
        points = prim.GetAttribute("points").Get(time)
    points = np.asarray(points, np.float64).reshape(-1, 3)
    n_points = len(points)
    skin = SkinData(skel_key=skel_key(skel_query), n_points=n_points)
    try:
        if sq.HasJointInfluences():
            check_skeleton(skel_query)
            joints, weights = _joint_influences(skel_query, sq, n_points, time, path, warnings)
            if not (weights != 0).any():
                raise BindingError("every jointWeight is 0")
            pi = mesh_data.point_of_vertex
            skin.joints, skin.weights = joints[pi], weights[pi]
            if joints.shape[1] > MAX_ATTRIBUTE_INFLUENCES:
                skin.point_influences = influence_texels(joints, weights)
            skin.geom_bind = np.array(sq.GetGeomBindTransform(time), np.float64).T
            skin.method = "dqs" if str(sq.GetSkinningMethod()) == "dualQuaternion" else "lbs"
            # Bounds: every bound point lies within joint_radius[j] of its joint j
            # (in bind space), which the per-frame bound moves with the joint.
            n_j = len(skel_query.GetJointOrder())
            bind = np.array(skel_query.GetJointWorldBindTransforms(), np.float64).reshape(-1, 4, 4)
            centers = np.concatenate([bind[:, 3, :3], np.zeros((1, 3))])  # row-vector Gf
            skin.joint_centers = centers
            gp = points @ skin.geom_bind[:3, :3].T + skin.geom_bind[:3, 3]
            radius = np.zeros(n_j + 1)
            for c in range(joints.shape[1]):
                used = weights[:, c] != 0
                d = np.linalg.norm(gp[used] - centers[joints[used, c]], axis=1)
                np.maximum.at(radius, joints[used, c], d)
            skin.joint_radius = radius
            skin.joint_used = np.unique(joints[weights != 0])
        if sq.HasBlendShapes():
            _blend_shapes(sq, n_points, skin, path, warnings)
        if skin.joints is None and skin.shape_offsets is None:
            return False
    except BindingError as exc:
        warnings.append(f"{path}: malformed skel binding ({exc}); drawn unskinned")
        return False
    mesh_data.skin = skin
    return True


def skinned_points(prim, binding, time, warnings):
    """A bound gprim's points skinned by UsdSkel on the CPU at `time`, in the
    skeleton's space (the prim's own transform then ignored, as for meshes), for
    gprims whose surface is made from their points each time they are read (curves);
    None, with a warning, where UsdSkel cannot skin them."""
    skel_query, sq = binding
    points = prim.GetAttribute("points").Get(time)
    if points is None:
        return None
    xforms = skel_query.ComputeSkinningTransforms(time)
    if xforms is None or not sq.ComputeSkinnedPoints(xforms, points, time):
        warnings.append(f"{prim.GetPath()}: its skel binding could not skin its points; "
                        f"drawn unskinned")
        return None
    return np.asarray(points, np.float64).reshape(-1, 3)


def pose(skel_query, time, dqs, warnings=None) -> SkelPose:
    """The skinning transforms at `time`. Non-finite ones (a NaN rotation in the
    animation) give the rest pose instead, with a warning naming the animation."""
    n = len(skel_query.GetJointOrder())
    xf = np.array(skel_query.ComputeSkinningTransforms(time), np.float64).reshape(-1, 4, 4)
    if len(xf) != n or unfit_items(xf).any():
        anim = skel_query.GetAnimQuery()
        where = anim.GetPrim().GetPath() if anim else skel_query.GetPrim().GetPath()
        when = "" if time.IsDefault() else f" at time {time.GetValue():g}"
        if warnings is not None:
            warnings.append(f"{where}: joint transforms are {NOT_FINITE}{when}; the skeleton "
                            f"is drawn in its rest pose")
        xf = _rest_skinning(skel_query)
    xf = np.concatenate([xf.transpose(0, 2, 1), np.eye(4)[None]])
    return SkelPose(xforms=xf, dqs=dqs)


def _rest_skinning(skel_query):
    """Skinning transforms of the rest pose (row-vector, as UsdSkel's): inverse bind
    times rest skel-space transforms; identity wherever that is not finite."""
    n = len(skel_query.GetJointOrder())
    skel = np.array(skel_query.ComputeJointSkelTransforms(Usd.TimeCode.Default(), True),
                    np.float64).reshape(-1, 4, 4)
    bind = np.array(skel_query.GetJointWorldBindTransforms(), np.float64).reshape(-1, 4, 4)
    out = np.tile(np.eye(4), (n, 1, 1))
    if len(skel) == n and len(bind) == n:
        with np.errstate(all="ignore"):
            xf = np.linalg.pinv(bind) @ skel
        ok = np.isfinite(xf).all(axis=(1, 2))
        out[ok] = xf[ok]
    return out


def blend_weights(skel_query, sq, bsq_cache, prim, time):
    """[(sub-shape, weight)] with non-zero weight this frame."""
    anim = skel_query.GetAnimQuery()
    if not anim:
        return []
    w = anim.ComputeBlendShapeWeights(time)
    if w is None or not len(w):
        return []
    mapper = sq.GetBlendShapeMapper()
    if mapper and not mapper.IsNull() and not mapper.IsIdentity():
        # The animation's blend shapes in the mesh's order (float weights: a Python
        # 0.0 default would be a double, which UsdSkel refuses); shapes the animation
        # lacks get 0.
        w = mapper.Remap(Vt.FloatArray(w))
    key = str(prim.GetPath())
    bsq = bsq_cache.get(key)
    if bsq is None:
        bsq = bsq_cache[key] = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
    sub_w, _, sub_i = bsq.ComputeSubShapeWeights(w)
    return [(int(i), float(x)) for i, x in zip(sub_i, sub_w) if x != 0.0]




def pose_might_vary(skel_query) -> bool:
    anim = skel_query.GetAnimQuery()
    return bool(anim) and anim.JointTransformsMightBeTimeVarying()


def weights_might_vary(skel_query) -> bool:
    anim = skel_query.GetAnimQuery()
    return bool(anim) and anim.BlendShapeWeightsMightBeTimeVarying()
