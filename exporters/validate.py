"""Runs pxr's registered validators on a stage, plus UsdSkel checks they miss."""
import numpy as np
from pxr import Usd, UsdGeom, UsdShade, UsdSkel, UsdValidation

WEIGHT_SUM_TOLERANCE = 1e-5


def _register_connectable_behaviors(stage):
    # Validators run in parallel, and UsdShade registers a prim type's connectable
    # behaviour lazily; two threads doing so at once raise a Tf error. Do it here,
    # serially, first.
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)):
        UsdShade.ConnectableAPI(prim).IsContainer()


def validation_errors(stage):
    """Messages of every Error-severity finding of every registered validator."""
    _register_connectable_behaviors(stage)
    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    errors = []
    for err in context.Validate(stage):
        if err.GetType() == UsdValidation.ValidationErrorType.Error:
            errors.append(f"{err.GetName()}: {err.GetMessage()}")
    return errors + skel_errors(stage)


def _joint_errors(path, joints):
    errors, seen = [], set()
    for i, joint in enumerate(joints):
        if joint in seen:
            errors.append(f"{path}: joint '{joint}' is listed twice")
        parent = joint.rpartition("/")[0]
        if parent and parent not in seen:
            errors.append(f"{path}: joint '{joint}' (index {i}) comes before its parent")
        seen.add(joint)
    return errors


def _sample_times(attr):
    return attr.GetTimeSamples() or [Usd.TimeCode.Default()]


def _skeleton_errors(skel):
    path = skel.GetPath()
    joints = list(skel.GetJointsAttr().Get() or [])
    errors = _joint_errors(path, joints)
    for name in ("bindTransforms", "restTransforms", "jointNames"):
        value = skel.GetPrim().GetAttribute(name).Get()
        if value is None or len(value) != len(joints):
            errors.append(f"{path}: {name} does not have one entry per joint")
    names = skel.GetPrim().GetAttribute("lantern:jointNames").Get()
    if names is not None and len(names) != len(joints):
        errors.append(f"{path}: lantern:jointNames does not have one entry per joint")
    return errors


def _animation_errors(anim):
    path = anim.GetPath()
    joints = list(anim.GetJointsAttr().Get() or [])
    errors = _joint_errors(path, joints)
    for attr in (anim.GetTranslationsAttr(), anim.GetRotationsAttr(), anim.GetScalesAttr()):
        if not attr.HasAuthoredValue():
            errors.append(f"{path}: {attr.GetName()} is not authored")
            continue
        if any(len(attr.Get(t)) != len(joints) for t in _sample_times(attr)):
            errors.append(f"{path}: {attr.GetName()} does not have one value per joint")
    shapes = anim.GetBlendShapesAttr().Get()
    if shapes:
        weights = anim.GetBlendShapeWeightsAttr()
        if not weights.HasAuthoredValue() or any(
                len(weights.Get(t)) != len(shapes) for t in _sample_times(weights)):
            errors.append(f"{path}: blendShapeWeights do not match blendShapes")
    return errors


def _skin_errors(prim, skeletons):
    path, errors = prim.GetPath(), []
    binding = UsdSkel.BindingAPI(prim)
    target = binding.GetSkeletonRel().GetTargets()
    skel = skeletons.get(target[0]) if target else None
    if skel is None:
        return [f"{path}: skel:skeleton does not target a Skeleton"]
    indices_pv, weights_pv = binding.GetJointIndicesPrimvar(), binding.GetJointWeightsPrimvar()
    size = indices_pv.GetElementSize()
    if size != weights_pv.GetElementSize():
        errors.append(f"{path}: jointIndices and jointWeights elementSize differ")
    indices = np.array(indices_pv.Get() or [], dtype=np.int64)
    weights = np.array(weights_pv.Get() or [], dtype=np.float64)
    points = UsdGeom.Mesh(prim).GetPointsAttr().Get() if prim.IsA(UsdGeom.Mesh) else None
    count = 1 if indices_pv.GetInterpolation() == UsdGeom.Tokens.constant else \
        (len(points) if points is not None else len(indices) // max(size, 1))
    if len(indices) != count * size or len(weights) != count * size:
        errors.append(f"{path}: skin arrays are not elementSize ({size}) per point")
        return errors
    if len(indices) and (indices.min() < 0 or indices.max() >= len(skel)):
        errors.append(f"{path}: joint index outside the skeleton's {len(skel)} joints")
    sums = weights.reshape(-1, size).sum(axis=1) if size else weights
    if len(sums) and np.abs(sums - 1).max() > WEIGHT_SUM_TOLERANCE:
        errors.append(f"{path}: joint weights do not sum to 1 (worst {sums[np.abs(sums - 1).argmax()]})")
    shapes = binding.GetBlendShapesAttr().Get() or []
    targets = binding.GetBlendShapeTargetsRel().GetTargets()
    if len(shapes) != len(targets):
        errors.append(f"{path}: skel:blendShapes and skel:blendShapeTargets differ in length")
    for target in targets:
        shape = UsdSkel.BlendShape(prim.GetStage().GetPrimAtPath(target))
        offsets = shape.GetOffsetsAttr().Get() if shape else None
        point_indices = shape.GetPointIndicesAttr().Get() if shape else None
        if offsets is None or (point_indices is not None and len(point_indices) != len(offsets)):
            errors.append(f"{target}: offsets and pointIndices differ in length")
        elif points is not None and point_indices is not None and len(point_indices) and \
                max(point_indices) >= len(points):
            errors.append(f"{target}: a point index is outside the mesh")
    return errors


def skel_errors(stage):
    """Joint order and uniqueness, channel completeness, skin array consistency, joint
    index range and weight sums: what UsdValidation does not check."""
    errors, skeletons = [], {}
    prims = list(Usd.PrimRange.Stage(stage))
    for prim in prims:
        if prim.IsA(UsdSkel.Skeleton):
            skel = UsdSkel.Skeleton(prim)
            errors += _skeleton_errors(skel)
            skeletons[prim.GetPath()] = list(skel.GetJointsAttr().Get() or [])
        elif prim.IsA(UsdSkel.Animation):
            errors += _animation_errors(UsdSkel.Animation(prim))
    for prim in prims:
        if prim.HasAPI(UsdSkel.BindingAPI) and not prim.IsA(UsdSkel.Skeleton):
            errors += _skin_errors(prim, skeletons)
    return errors
