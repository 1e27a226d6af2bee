"""UsdSkel on the GPU: reading bindings (pxr), per-frame joint data (numpy), and the
GL side (textures, vertex attributes, shader variants, transform-feedback readback).

UsdSkel's convention, which the shader follows (shaders/skinning.glsl):
  blend shapes first, on the mesh's own points:  P = points + sum_s w_s * offset_s
  then P' = sum_j w_j * X_j * (G * P)   (LBS; X_j = ComputeSkinningTransforms, G =
  geomBindTransform), in skeleton space, drawn with the skeleton's local-to-world.
  DQS splits X_j = T_j R_j S_j (polar decomposition of its 3x3): the scale parts are
  blended linearly on the point, the rigid parts as dual quaternions.
Weights are used as authored (UsdSkel does not renormalise them). Up to 8
influences per point travel as vertex attributes; a mesh with more reads all of
them from a per-point influence texture instead, so no influence is ever dropped.

Per frame the CPU does one joint-texture upload per skeleton and one small active
blend-shape list per mesh; nothing per vertex."""
from __future__ import annotations

import numpy as np
from pxr import Usd, UsdSkel, Vt

from .scene import SkelPose, SkinData

MAX_ATTRIBUTE_INFLUENCES = 8   # beyond this, influences come from a texture
SHAPE_TEX_W = 4096          # texels per row of the blend-shape offsets texture
UNIT_JOINTS, UNIT_SHAPES, UNIT_ACTIVE, UNIT_INFLUENCES = 8, 9, 10, 11  # above the material units
LBS_TEXELS, DQS_TEXELS = 6, 14


class BindingError(ValueError):
    pass


# --- reading ---------------------------------------------------------------------

class SkelBindings:
    """mesh path -> (SkeletonQuery, SkinningQuery) for every SkelRoot of a stage,
    populated once (a sequence reuses it)."""

    def __init__(self, stage):
        self.cache = UsdSkel.Cache()
        self.by_mesh = {}
        pred = Usd.TraverseInstanceProxies()
        for prim in Usd.PrimRange(stage.GetPseudoRoot(), pred):
            if not prim.IsA(UsdSkel.Root):
                continue
            root = UsdSkel.Root(prim)
            self.cache.Populate(root, pred)
            for binding in self.cache.ComputeSkelBindings(root, pred):
                skel_query = self.cache.GetSkelQuery(binding.GetSkeleton())
                if not skel_query:
                    continue
                for sq in binding.GetSkinningTargets():
                    self.by_mesh[str(sq.GetPrim().GetPath())] = (skel_query, sq)

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


def attach_skin(mesh_data, prim, binding, time, warnings) -> bool:
    """Adds a SkinData to a freshly built MeshData. A malformed binding leaves the
    mesh unskinned with a warning naming it and the reason; returns whether skinned."""
    skel_query, sq = binding
    path = str(prim.GetPath())
    points = np.asarray(prim.GetAttribute("points").Get(time), np.float64).reshape(-1, 3)
    n_points = len(points)
    skin = SkinData(skel_key=skel_key(skel_query), n_points=n_points)
    try:
        if sq.HasJointInfluences() and len(skel_query.GetJointOrder()):
            joints, weights = _joint_influences(skel_query, sq, n_points, time, path, warnings)
            pi = mesh_data.point_index
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
            if _blend_shapes(sq, n_points, skin, path, warnings) is None:
                pass
        if skin.joints is None and skin.shape_offsets is None:
            return False
    except BindingError as exc:
        warnings.append(f"{path}: malformed skel binding ({exc}); drawn unskinned")
        return False
    mesh_data.skin = skin
    return True


def pose(skel_query, time, dqs) -> SkelPose:
    xf = np.array(skel_query.ComputeSkinningTransforms(time), np.float64).reshape(-1, 4, 4)
    xf = np.concatenate([xf.transpose(0, 2, 1), np.eye(4)[None]])
    return SkelPose(xforms=xf, dqs=dqs)


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
        w = mapper.Remap(w, Vt.FloatArray(), 1, 0.0)
    key = str(prim.GetPath())
    bsq = bsq_cache.get(key)
    if bsq is None:
        bsq = bsq_cache[key] = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
    sub_w, _, sub_i = bsq.ComputeSubShapeWeights(w)
    return [(int(i), float(x)) for i, x in zip(sub_i, sub_w) if x != 0.0]


# --- per-frame joint data ----------------------------------------------------------

def _quat_from_rot(R):
    """(n,3,3) proper rotations -> (n,4) quaternions x,y,z,w."""
    n = len(R)
    q = np.zeros((n, 4))
    tr = np.trace(R, axis1=1, axis2=2)
    cands = np.stack([tr, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], 1)
    k = np.argmax(cands, axis=1)
    for case in range(4):
        s = k == case
        if not np.any(s):
            continue
        r = R[s]
        if case == 0:
            t = np.sqrt(1 + tr[s]) * 2
            q[s] = np.stack([(r[:, 2, 1] - r[:, 1, 2]) / t, (r[:, 0, 2] - r[:, 2, 0]) / t,
                             (r[:, 1, 0] - r[:, 0, 1]) / t, 0.25 * t], 1)
        else:
            i = case - 1
            j, kk = (i + 1) % 3, (i + 2) % 3
            t = np.sqrt(np.maximum(1 + r[:, i, i] - r[:, j, j] - r[:, kk, kk], 1e-30)) * 2
            v = np.zeros((len(r), 4))
            v[:, i] = 0.25 * t
            v[:, j] = (r[:, j, i] + r[:, i, j]) / t
            v[:, kk] = (r[:, kk, i] + r[:, i, kk]) / t
            v[:, 3] = (r[:, kk, j] - r[:, j, kk]) / t
            q[s] = v
    return q


def _qmul(a, b):
    ax, ay, az, aw = a.T
    bx, by, bz, bw = b.T
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], 1)


def _inv_t(m3):
    det = np.linalg.det(m3)
    safe = np.where(np.abs(det) > 1e-30, 1.0, 0.0)[:, None, None]
    inv = np.linalg.inv(np.where(safe > 0, m3, np.eye(3)))
    return np.where(safe > 0, inv.transpose(0, 2, 1), m3)


def joint_texels(xforms, dqs=False) -> np.ndarray:
    """(n, 4, 4) skinning transforms -> (n, 6|14, 4) float32 texture rows, one joint
    per row: texels 0-2 the 3x4 matrix rows, 3-5 the rows of its 3x3 inverse
    transpose (normals); with dqs also 6 the rotation quaternion, 7 the dual part,
    8-10 the scale matrix rows, 11-13 the scale's inverse transpose rows."""
    n = len(xforms)
    out = np.zeros((n, DQS_TEXELS if dqs else LBS_TEXELS, 4))
    out[:, 0:3, :] = xforms[:, :3, :]
    m3 = xforms[:, :3, :3]
    out[:, 3:6, :3] = _inv_t(m3)
    if dqs:
        # Polar decomposition M3 = R S, as Gf's Factor + Orthonormalize gives it.
        U, _, Vt_ = np.linalg.svd(m3)
        R = U @ Vt_
        flip = np.linalg.det(R) < 0
        U[flip, :, 2] *= -1
        R = U @ Vt_
        S = R.transpose(0, 2, 1) @ m3
        q = _quat_from_rot(R)
        t = np.concatenate([xforms[:, :3, 3], np.zeros((n, 1))], 1)
        out[:, 6] = q
        out[:, 7] = 0.5 * _qmul(t, q)
        out[:, 8:11, :3] = S
        out[:, 11:14, :3] = _inv_t(S)
    return np.ascontiguousarray(out, np.float32)


def local_bounds(skin, pose_, shapes, rest_lo, rest_hi):
    """Conservative AABB, in the space the mesh is drawn in, of a skinned mesh this
    frame: each used joint's current position padded by its bind-space radius (plus
    the largest blend-shape displacement) times the joint's largest scale. Assumes
    weights summing to one, as UsdSkel expects. Blend shapes alone: the rest bounds
    padded."""
    pad = 0.0
    if skin.shape_max is not None:
        pad = sum(abs(w) * float(skin.shape_max[i]) for i, w in shapes if i < len(skin.shape_max))
    if skin.joints is None or pose_ is None:
        return rest_lo - pad, rest_hi + pad
    xf = pose_.xforms[:len(skin.joint_radius)]
    used = skin.joint_used
    m = xf[used]
    centers = np.einsum("nij,nj->ni", m[:, :3, :3], skin.joint_centers[used]) + m[:, :3, 3]
    scale = np.linalg.norm(m[:, :3, :3], axis=1).max(axis=1)
    g_scale = float(np.linalg.norm(skin.geom_bind[:3, :3], axis=0).max())
    r = ((skin.joint_radius[used] + pad * g_scale) * scale)[:, None]
    return (centers - r).min(axis=0), (centers + r).max(axis=0)


def transform_aabb(lo, hi, m):
    corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    w = corners @ m.T
    p = w[:, :3] / w[:, 3:4]
    return p.min(axis=0), p.max(axis=0)


def frustum_planes(view_proj):
    """Gribb-Hartmann: the six planes (a, b, c, d), inside when a x + b y + c z + d >= 0."""
    m = view_proj
    planes = np.array([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1],
                       m[3] + m[2], m[3] - m[2]])
    return planes / np.maximum(np.linalg.norm(planes[:, :3], axis=1, keepdims=True), 1e-30)


def aabb_outside(planes, lo, hi) -> bool:
    """True when the box is wholly outside one plane (so outside the frustum)."""
    p = np.where(planes[:, :3] >= 0, hi, lo)      # the corner furthest along each normal
    return bool(np.any(np.einsum("ij,ij->i", planes[:, :3], p) + planes[:, 3] < 0))


# --- GL ----------------------------------------------------------------------------

def defines(skin):
    if skin is None:
        return []
    out = []
    if skin.shape_offsets is not None:
        out.append("SKIN_SHAPES")
    if skin.joints is not None:
        out.append("SKIN_JOINTS")
        k = skin.joints.shape[1]
        if k > MAX_ATTRIBUTE_INFLUENCES:
            out.append("SKIN_JOINTS_TEX")
        elif k > 4:
            out.append("SKIN_JOINTS8")
        if skin.method == "dqs":
            out.append("SKIN_DQS")
    return out


def vertex_data(mesh):
    """(bytes, moderngl format, attribute names) of a skinned mesh's extra stream."""
    skin = mesh.skin
    n = len(mesh.vertices)
    cols, fmt, names = [mesh.point_index.astype(np.int32).reshape(n, 1).view(np.float32)], ["1i"], ["in_point"]
    if skin.joints is not None and skin.point_influences is None:
        k = skin.joints.shape[1]
        for h in range(k // 4):
            cols += [skin.joints[:, 4 * h:4 * h + 4].astype(np.int32).view(np.float32),
                     skin.weights[:, 4 * h:4 * h + 4].astype(np.float32)]
            fmt += ["4i", "4f"]
            names += [f"in_joints{h}", f"in_weights{h}"]
    data = np.ascontiguousarray(np.concatenate(cols, axis=1), np.float32)
    return data.tobytes(), " ".join(fmt), names


def float_texture(ctx, texels):
    """(h, w, 4) float32 -> an RGBA32F texture, nearest, for texelFetch."""
    texels = np.ascontiguousarray(texels, np.float32)
    h, w = texels.shape[:2]
    tex = ctx.texture((w, h), 4, texels.tobytes(), dtype="f4")
    tex.filter = (ctx.NEAREST, ctx.NEAREST)
    return tex


def influence_texels(joints, weights):
    """(n_points, 4g) joints and weights -> flat texels, per point g pairs of
    (4 joint indices as floats, exact below 2^24; 4 weights), as the shader reads them."""
    n, k = joints.shape
    groups = np.stack([joints.reshape(n, k // 4, 4).astype(np.float32),
                       weights.reshape(n, k // 4, 4).astype(np.float32)], axis=2)
    return groups.reshape(-1, 4)


def flat_texture(ctx, texels):
    """(n, 4) float32 texels -> a SHAPE_TEX_W-wide RGBA32F texture (row-major)."""
    rows = -(-len(texels) // SHAPE_TEX_W)
    data = np.zeros((rows * SHAPE_TEX_W, 4), np.float32)
    data[:len(texels)] = texels
    return float_texture(ctx, data.reshape(rows, SHAPE_TEX_W, 4))


def shape_texture(ctx, skin):
    off = skin.shape_offsets
    return flat_texture(ctx, np.concatenate([off, np.zeros((len(off), 1))], axis=1))


def active_texels(skin, shapes):
    """One texel per active sub-shape: point-offset block, normal block, weight."""
    rows = [(skin.shape_blocks[i][0], skin.shape_blocks[i][1], w, 0.0)
            for i, w in shapes if i < len(skin.shape_blocks) and max(skin.shape_blocks[i]) >= 0]
    return np.array(rows or [(-1, -1, 0, 0)], np.float32).reshape(1, -1, 4), len(rows)


def set_skin_uniforms(prog, skin, n_active, set_uniform):
    set_uniform(prog, "u_joint_xforms", UNIT_JOINTS)
    set_uniform(prog, "u_shape_offsets", UNIT_SHAPES)
    set_uniform(prog, "u_shape_active", UNIT_ACTIVE)
    set_uniform(prog, "u_influences", UNIT_INFLUENCES)
    if skin.joints is not None:
        set_uniform(prog, "u_influence_groups", int(skin.joints.shape[1] // 4))
    set_uniform(prog, "u_shape_count", int(n_active))
    set_uniform(prog, "u_shape_points", int(skin.n_points))
    set_uniform(prog, "u_geom_bind", skin.geom_bind)
    g3 = skin.geom_bind[:3, :3]
    set_uniform(prog, "u_geom_bind_normal", np.linalg.inv(g3).T
                if abs(np.linalg.det(g3)) > 1e-30 else g3)


_tf_programs = {}


def readback(frame) -> dict:
    """Transform feedback of every skinned draw of a FrameRenderer's scene through
    skinning.glsl: {path: (world points (n_points, 3), world normals)}."""
    from .shaders import load_source
    ctx, out = frame.ctx, {}
    # A surfaceless context has no default framebuffer, and a draw without one fails
    # even with rasterisation off: bind a throwaway target.
    frame.own(ctx.simple_framebuffer((1, 1))).use()
    for draw in frame.scene.draws:
        mesh = frame.scene.meshes[draw.mesh_key]
        if mesh.skin is None or not len(mesh.vertices):
            continue
        defs = tuple(sorted(defines(mesh.skin)))
        key = (id(ctx), defs)
        prog = _tf_programs.get(key)
        if prog is None:
            prog = _tf_programs[key] = ctx.program(
                vertex_shader=load_source("skin_readback.vert", defs),
                varyings=["out_pos", "out_normal"])
        vao = frame.mesh_vao(prog, mesh)
        frame.bind_skin(prog, draw, mesh)
        n = len(mesh.vertices)
        buf = frame.own(ctx.buffer(reserve=n * 24))
        vao.transform(buf, mode=ctx.POINTS, vertices=n)
        data = np.frombuffer(buf.read(), np.float32).reshape(n, 6).astype(np.float64)
        pts = np.zeros((mesh.skin.n_points, 3))
        nrm = np.zeros((mesh.skin.n_points, 3))
        pts[mesh.point_index] = data[:, :3]
        nrm[mesh.point_index] = data[:, 3:]
        w = draw.world
        pts = pts @ w[:3, :3].T + w[:3, 3]
        m3 = w[:3, :3]
        nrm = nrm @ (np.linalg.inv(m3).T if abs(np.linalg.det(m3)) > 1e-30 else m3).T
        out[draw.prim_path] = (pts, nrm)
    return out
