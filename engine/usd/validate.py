"""Checks of what the stage reader reads that name the prim at fault: non-finite
transform values and material bindings to prims that are not Materials."""
from __future__ import annotations

import math

import numpy as np
from pxr import UsdGeom, UsdShade


def finite_value(v) -> bool:
    """Whether an xform op's value (a number, vector, matrix or quaternion) is finite."""
    if isinstance(v, (int, float)):
        return math.isfinite(v)
    if hasattr(v, "GetReal"):
        return math.isfinite(v.GetReal()) and all(math.isfinite(x) for x in v.GetImaginary())
    if len(v) <= 4 and not hasattr(v[0], "__len__"):         # a vector: no array made
        return all(math.isfinite(x) for x in v)
    return bool(np.isfinite(np.asarray(v, np.float64)).all())


def check_binding(prim, warnings):
    """A direct binding whose target is not a Material: say so."""
    rel = UsdShade.MaterialBindingAPI(prim).GetDirectBindingRel()
    for target in (rel.GetTargets() if rel else []):
        p = prim.GetStage().GetPrimAtPath(target)
        if not p or not p.IsA(UsdShade.Material):
            what = "does not exist" if not p else f"is a {p.GetTypeName() or 'typeless prim'}"
            warnings.append(f"{prim.GetPath()}: its material binding {target} {what}; "
                            f"using the default material")


def first_bad_op(prim, time, memo: dict, orient_only: bool = False):
    """'<prim path>.<op>' of the first non-finite xform op at or above `prim` at
    `time`, or None; `memo` (prim path -> answer) holds for one time and one
    `orient_only`. orient_only: only quaternion ops, the ones composition hides (it
    takes a non-finite quaternion as the identity; any other op's non-finite value
    makes the world matrix non-finite)."""
    path = str(prim.GetPath())
    if path not in memo:
        bad = None
        xf = UsdGeom.Xformable(prim)
        for op in (xf.GetOrderedXformOps() if xf else []):
            if orient_only and op.GetOpType() != UsdGeom.XformOp.TypeOrient:
                continue
            v = op.Get(time)
            if v is not None and not finite_value(v):
                bad = f"{path}.{op.GetOpName()}"
                break
        parent = prim.GetParent()
        if bad is None and parent and not parent.IsPseudoRoot():
            bad = first_bad_op(parent, time, memo, orient_only)
        memo[path] = bad
    return memo[path]
