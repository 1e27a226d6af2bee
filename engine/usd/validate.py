"""Checks of what the stage reader reads that name the prim at fault: values that are
not finite in float32, and material bindings to prims that are not Materials.

Finite here means finite in float32, what the GPU's tables and buffers hold: NaN,
Inf, and a double beyond float32's range (1e300 is finite in a double and Inf once
cast) are refused alike, by these functions, wherever the readers take numbers from
the stage (lights, transforms, points, primvars)."""
from __future__ import annotations

import numpy as np
from pxr import UsdGeom, UsdShade

FLOAT32_MAX = float(np.finfo(np.float32).max)
NOT_FINITE = "not finite in float32"        # the reason given for every such value
ORIENT_OP = "xformOp:orient"                 # the quaternion ops' attribute names


def fits(x: float) -> bool:
    """Whether a number is finite in float32 (NaN compares False)."""
    return -FLOAT32_MAX <= x <= FLOAT32_MAX


def unfit_items(values) -> np.ndarray:
    """Per item (along the first axis), whether any of its numbers is not finite in
    float32."""
    v = np.asarray(values, np.float64)
    ok = np.abs(v) <= FLOAT32_MAX
    return ~ok.all(axis=tuple(range(1, v.ndim)))     # no items: an empty answer


def check_items(values, what, error=ValueError):
    """`error` naming how many of the `what` are not finite in float32, if any are."""
    bad = unfit_items(values)
    if bad.any():
        raise error(f"{int(bad.sum())} of {len(bad)} {what} are {NOT_FINITE}")


def finite_value(v) -> bool:
    """Whether an xform op's value (a number, vector, matrix or quaternion) is finite
    in float32."""
    if isinstance(v, (int, float)):
        return fits(v)
    if hasattr(v, "GetReal"):
        return fits(v.GetReal()) and all(fits(x) for x in v.GetImaginary())
    if len(v) <= 4 and not hasattr(v[0], "__len__"):         # a vector: no array made
        return all(fits(x) for x in v)
    return not unfit_items(np.asarray(v, np.float64).reshape(1, -1)).any()


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
    """'<prim path>.<op>' of the first xform op not finite in float32 at or above
    `prim` at `time`, or None; `memo` (prim path -> answer) holds for one time and one
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
