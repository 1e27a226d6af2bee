"""UsdGeom.PointInstancer and UsdGeom.Points -> plain arrays (no records, no GL).

PointInstancer: each instance's matrix, computed in numpy for all instances at once
as UsdGeom.PointInstancer.ComputeInstanceTransformsAtTime does (column-vector):
    instance i = T(positions[i]) . R(orientations[i]) . S(scales[i]) . protoXform
where protoXform is the prototype root's own local transform (IncludeProtoXform),
orientations are `orientationsf` (float) when authored, else the half `orientations`.
`invisibleIds` and `inactiveIds` mask instances out (ComputeMaskAtTime). A mesh
inside a prototype is drawn at  instancer world . instance i . (mesh relative to
the prototype root); a PointInstancer inside a prototype draws its own prototypes
there, its instance matrices composed with the outer ones. Velocities and
accelerations are not applied (instances sit at their authored samples). What cannot be drawn is a warning naming the instancer:
no prototypes, protoIndices out of range, non-finite positions, orientations or
scales, arrays whose lengths do not match; those instances are skipped.

Points: positions, per-point (or constant) widths (default 1, as Storm), per-point
or constant displayColor."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom

from .gprims import kind_of
from .validate import NOT_FINITE, check_items, unfit_items


def _array(attr, time, dtype=np.float64):
    if not attr or not attr.HasValue():
        return None
    v = attr.Get(time)
    return None if v is None else np.asarray(v, dtype)


def _quats(attr, time):
    """(n, 4) w, x, y, z from a quat array attribute, or None."""
    if not attr or not attr.HasValue():
        return None
    v = attr.Get(time)
    if v is None:
        return None
    return np.array([[q.GetReal(), *q.GetImaginary()] for q in v], np.float64).reshape(-1, 4)


def rotation_matrices(q):
    """(n, 4) quaternions (w, x, y, z), normalised here -> (n, 3, 3)."""
    n = np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(n > 0, q / np.where(n > 0, n, 1), [1.0, 0, 0, 0])
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def instance_matrices(prim, time, warnings):
    """(prototype prim paths, proto index per instance (n,), instance matrices
    (n, 4, 4) column-vector without protoXform, kept mask (n,)) in the instancer's
    space; warnings name the instancer and what was skipped."""
    path = str(prim.GetPath())
    pi = UsdGeom.PointInstancer(prim)
    protos = [str(t) for t in pi.GetPrototypesRel().GetForwardedTargets()]
    indices = _array(pi.GetProtoIndicesAttr(), time, np.int64)
    positions = _array(pi.GetPositionsAttr(), time)
    if not protos:
        warnings.append(f"{path}: a PointInstancer without prototypes; nothing drawn")
        return protos, np.zeros(0, np.int64), np.zeros((0, 4, 4)), np.zeros(0, bool)
    if indices is None or positions is None:
        warnings.append(f"{path}: a PointInstancer without protoIndices or positions; "
                        f"nothing drawn")
        return protos, np.zeros(0, np.int64), np.zeros((0, 4, 4)), np.zeros(0, bool)
    n = len(indices)
    keep = np.ones(n, bool)
    if len(positions) != n:
        warnings.append(f"{path}: {len(positions)} positions for {n} protoIndices; nothing drawn")
        return protos, indices, np.zeros((n, 4, 4)), np.zeros(n, bool)
    positions = positions.reshape(n, 3)
    m = np.tile(np.eye(4), (n, 1, 1))
    q = _quats(pi.GetOrientationsfAttr(), time)
    if q is None:
        q = _quats(pi.GetOrientationsAttr(), time)
    if q is not None:
        if len(q) != n:
            warnings.append(f"{path}: {len(q)} orientations for {n} instances; ignored")
        else:
            m[:, :3, :3] = rotation_matrices(q)
    scales = _array(pi.GetScalesAttr(), time)
    if scales is not None:
        if len(scales) != n:
            warnings.append(f"{path}: {len(scales)} scales for {n} instances; ignored")
        else:
            m[:, :3, :3] *= scales.reshape(n, 1, 3)
    m[:, :3, 3] = positions
    bad_index = (indices < 0) | (indices >= len(protos))
    if bad_index.any():
        warnings.append(f"{path}: {int(bad_index.sum())} of {n} protoIndices are out of range "
                        f"(0..{len(protos) - 1}); those instances are skipped")
    finite = ~unfit_items(m)
    if not finite.all():
        warnings.append(f"{path}: {int((~finite).sum())} of {n} instances have positions, "
                        f"orientations or scales {NOT_FINITE}; skipped")
    keep &= ~bad_index & finite
    mask = pi.ComputeMaskAtTime(time)
    if mask is not None and len(mask) == n:
        keep &= np.asarray(mask, bool)
    return protos, indices, m, keep


def points_data(prim, time):
    """(points (n, 3) float64, radii (n,), colours (n, 3) or None) of a Points prim;
    ValueError naming the defect."""
    pts = UsdGeom.Points(prim)
    p = _array(pts.GetPointsAttr(), time)
    if p is None or not len(p):
        raise ValueError("no points")
    p = p.reshape(-1, 3)
    n = len(p)
    check_items(p, "points")
    w = _array(pts.GetWidthsAttr(), time)
    if w is None or not len(w):
        radii = np.full(n, 0.5)
    elif len(w) == 1:
        radii = np.full(n, float(w[0]) / 2)
    elif len(w) == n:
        radii = w / 2
    else:
        raise ValueError(f"{len(w)} widths for {n} points")
    check_items(radii, "widths")
    if (radii < 0).any():
        raise ValueError("widths are negative")
    colours = None
    pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
    if pv and pv.HasValue():
        c = pv.ComputeFlattened(time)
        if c is not None and len(c):
            c = np.asarray(c, np.float64).reshape(-1, 3)
            if len(c) == n:
                colours = c
            elif len(c) == 1:
                colours = np.repeat(c, n, axis=0)
            if colours is not None:
                check_items(colours, "displayColor values")
    return p, radii, colours


@dataclass
class Prototype:
    """What a prototype draws: `meshes` [(mesh prim, its placements in an instance
    (k, 4, 4), column-vector)]; `undrawn`: the Points and curve tubes found in it
    (not drawn); `instancers`: the PointInstancer prims nested in it and `protos`
    their prototypes' paths, at any depth (what an edit of re-reads the instancer)."""
    meshes: list = field(default_factory=list)
    undrawn: list = field(default_factory=list)
    instancers: list = field(default_factory=list)
    protos: list = field(default_factory=list)


def prototype_meshes(stage, proto_path, time, warnings, within=()) -> Prototype:
    """The drawable meshes in a prototype (Mesh prims, implicit surfaces, ribbons,
    patch hulls: gprims.kind_of 'mesh'; instance proxies included; invisible, proxy
    and guide prims skipped), each placed at the prototype root's own transform
    (IncludeProtoXform) times its transform relative to the root. A PointInstancer
    inside (the root itself, too) draws its own prototypes there, at every one of its
    instances: placed at the root's own transform . the nested instancer's relative
    to the root . its instance matrix . what its prototype places, to any depth, as
    Storm draws nested instancers. `within`: the instancers this prototype is drawn
    inside; one found again inside its own prototype is a warning, not drawn again."""
    out = Prototype()
    root = stage.GetPrimAtPath(proto_path)
    if not root:
        return out
    cache = UsdGeom.XformCache(time)
    xf = UsdGeom.Xformable(root)
    proto_xform = np.array(xf.GetLocalTransformation(time), np.float64).T if xf else np.eye(4)
    placements = {}                     # mesh path -> (prim, [placements])
    # Prototypes usually sit under a class prim (abstract, which the default predicate
    # would skip) or an `over` (undefined, so that they draw only as instances): each
    # prim needs a defining specifier of its own, not its ancestors'.
    predicate = Usd.TraverseInstanceProxies(Usd.PrimIsActive & Usd.PrimIsLoaded)
    it = iter(Usd.PrimRange(root, predicate))
    for p in it:
        if not p.HasDefiningSpecifier():
            continue
        img = UsdGeom.Imageable(p)
        if p != root and img and img.GetVisibilityAttr().Get() == UsdGeom.Tokens.invisible:
            it.PruneChildren()
            continue
        kind = kind_of(p)
        if p.IsA(UsdGeom.PointInstancer):                # the root itself, too
            it.PruneChildren()
            if str(p.GetPath()) in within:
                warnings.append(f"{p.GetPath()}: a PointInstancer inside its own prototype; "
                                f"not drawn again there")
                continue
            place = proto_xform @ _relative(cache, p, root)
            _nested(stage, p, place, time, warnings, within, out, placements)
        elif kind == "points":
            out.undrawn.append(str(p.GetPath()))
        elif kind == "mesh":
            if img.ComputePurpose() in (UsdGeom.Tokens.proxy, UsdGeom.Tokens.guide):
                continue
            placements.setdefault(str(p.GetPath()), (p, []))[1].append(
                (proto_xform @ _relative(cache, p, root))[None])
    out.meshes = [(prim, np.concatenate(mats)) for prim, mats in placements.values()]
    return out


def _relative(cache, prim, root):
    if prim == root:
        return np.eye(4)
    m, _ = cache.ComputeRelativeTransform(prim, root)
    return np.array(m, np.float64).T


def _nested(stage, instancer, place, time, warnings, within, out, placements):
    """Adds what a PointInstancer inside a prototype draws (placed at `place`) to
    `out` and `placements`."""
    path = str(instancer.GetPath())
    out.instancers.append(instancer)
    protos, indices, mats, keep = instance_matrices(instancer, time, warnings)
    for k, proto in enumerate(protos):
        sel = keep & (indices == k)
        out.protos.append(proto)
        if not sel.any():
            continue
        if not stage.GetPrimAtPath(proto):
            warnings.append(f"{path}: prototype {proto} does not exist; its "
                            f"{int(sel.sum())} instances are skipped")
            continue
        inner = prototype_meshes(stage, proto, time, warnings, within + (path,))
        out.undrawn += inner.undrawn
        out.instancers += inner.instancers
        out.protos += inner.protos
        placed = place @ mats[sel]
        for prim, rel in inner.meshes:
            placements.setdefault(str(prim.GetPath()), (prim, []))[1].append(
                (placed[:, None] @ rel[None]).reshape(-1, 4, 4))
