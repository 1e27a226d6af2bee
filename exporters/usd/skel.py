"""SkeletonRecord and SkinRecord -> UsdSkel: Skeleton, SkelAnimation, skin bindings,
BlendShapes (docs/stage_contract.md, "Skeletal animation")."""
import numpy as np
from pxr import Gf, Sdf, UsdSkel, Vt

from .names import Namer

STATIC_JOINT = "lantern_static"


def _matrices(blender):
    # Blender's matrices act on column vectors, USD's on row vectors: transpose.
    return Vt.Matrix4dArray.FromNumpy(np.ascontiguousarray(np.swapaxes(blender, -1, -2)))


def joint_paths(rec):
    """Joint tokens: sanitised bone names, unique among siblings, joined by '/'."""
    namer, paths = Namer(), []
    root = Sdf.Path.absoluteRootPath
    for name, parent in zip(rec.joint_names, rec.parents):
        parent_path = root if parent < 0 else root.AppendPath(paths[parent])
        paths.append(str(namer.child(parent_path, name))[1:])
    if rec.static_world is not None:
        paths.append(str(namer.child(root, STATIC_JOINT))[1:])
    return paths


def _channel(attr, values, times, convert):
    if len(values) == 1:
        attr.Set(convert(values[0]))
        return
    # One change notification for all samples instead of one per Set.
    with Sdf.ChangeBlock():
        for frame, value in zip(times, values):
            attr.Set(convert(value), frame)


def _with_static(values, rec, constant):
    """Appends the static joint's constant channel value to every sample."""
    if rec.static_world is None:
        return values
    count = len(values) if values is not None else 1
    extra = np.broadcast_to(np.asarray(constant, dtype=np.float64), (count, 1, len(constant)))
    if values is None:
        return extra
    return np.concatenate([values, extra], axis=1)


def write_skeleton(stage, parent_path, rec, namer):
    """Skeleton (and its SkelAnimation) under `parent_path`, the SkelRoot. Returns the
    skeleton's path and the blend shape tokens: (object key, key name) -> token."""
    path = namer.child(parent_path, rec.name)
    skel = UsdSkel.Skeleton.Define(stage, path)
    joints = joint_paths(rec)
    names = list(rec.joint_names)
    bind, rest = rec.bind, rec.rest
    if rec.static_world is not None:
        names.append("")
        bind = np.concatenate([bind, rec.static_world[None]])
        rest = np.concatenate([rest, np.eye(4)[None]])
    skel.CreateJointsAttr(Vt.TokenArray(joints))
    skel.CreateJointNamesAttr(Vt.TokenArray(names[:len(rec.joint_names)] +
                                            joints[len(rec.joint_names):]))
    skel.CreateBindTransformsAttr(_matrices(bind))
    skel.CreateRestTransformsAttr(_matrices(rest))
    skel.GetPrim().CreateAttribute("lantern:jointNames", Sdf.ValueTypeNames.StringArray,
                                   custom=True).Set(Vt.StringArray(names))

    if not rec.times:
        return path, {}
    anim_path = path.AppendChild("Animation")
    tokens = write_animation(stage, anim_path, rec, joints)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim_path])
    return path, tokens


def write_animation(stage, path, rec, joints):
    """The SkelAnimation of a rig: joint channels and blend-shape weights at its
    times. Returns the blend shape tokens: (object key, key name) -> token."""
    tokens = {}
    anim = UsdSkel.Animation.Define(stage, path)
    anim.CreateJointsAttr(Vt.TokenArray(joints))
    _channel(anim.CreateTranslationsAttr(), _with_static(rec.translations, rec, (0, 0, 0)),
             rec.times, lambda v: Vt.Vec3fArray.FromNumpy(v.astype(np.float32)))
    _channel(anim.CreateRotationsAttr(), _with_static(rec.rotations, rec, (0, 0, 0, 1)),
             rec.times, lambda v: Vt.QuatfArray.FromNumpy(v.astype(np.float32)))
    _channel(anim.CreateScalesAttr(), _with_static(rec.scales, rec, (1, 1, 1)),
             rec.times, lambda v: Vt.Vec3hArray.FromNumpy(v.astype(np.float16)))
    if rec.blend_shapes:
        # Tokens unique in the rig, since two meshes may both have a key "Smile".
        token_namer = Namer()
        for object_key, shape in rec.blend_shapes:
            tokens[(object_key, shape)] = token_namer.child(
                Sdf.Path.absoluteRootPath, f"{object_key}_{shape}").name
        anim.CreateBlendShapesAttr(Vt.TokenArray([tokens[s] for s in rec.blend_shapes]))
        _channel(anim.CreateBlendShapeWeightsAttr(), rec.blend_weights, rec.times,
                 lambda v: Vt.FloatArray.FromNumpy(v.astype(np.float32)))
    return tokens


def bind_skin(stage, mesh_path, skin, skeleton_path, shape_tokens, max_influences=None):
    """Skin primvars, skinning method, geomBindTransform and blend shapes on a Mesh."""
    mesh_prim = stage.GetPrimAtPath(mesh_path)
    binding = UsdSkel.BindingAPI.Apply(mesh_prim)
    binding.CreateSkeletonRel().SetTargets([skeleton_path])
    width = skin.joint_indices.shape[1]
    indices = Vt.IntArray.FromNumpy(np.ascontiguousarray(skin.joint_indices.ravel()))
    weights = Vt.FloatArray.FromNumpy(np.ascontiguousarray(skin.joint_weights.ravel()))
    UsdSkel.SortInfluences(indices, weights, width)
    UsdSkel.NormalizeWeights(weights, width)
    if max_influences is not None and 0 < max_influences < width:
        UsdSkel.ResizeInfluences(indices, width, max_influences)
        UsdSkel.ResizeInfluences(weights, width, max_influences)
        width = max_influences
    binding.CreateJointIndicesPrimvar(False, width).Set(indices)
    binding.CreateJointWeightsPrimvar(False, width).Set(weights)
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(skin.geom_bind.T.tolist()))
    binding.CreateSkinningMethodAttr(UsdSkel.Tokens.dualQuaternion if skin.dual_quaternion
                                     else UsdSkel.Tokens.classicLinear)
    shapes = [s for s in skin.blend_shapes if len(s.indices)]
    if not shapes:
        return
    namer, targets = Namer(), []
    for child in mesh_prim.GetAllChildren():  # material subsets
        namer.reserve(mesh_path, child.GetName())
    for shape in shapes:
        shape_path = namer.child(mesh_path, shape.name)
        blend = UsdSkel.BlendShape.Define(stage, shape_path)
        blend.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(shape.offsets)))
        blend.CreatePointIndicesAttr(Vt.IntArray.FromNumpy(shape.indices))
        targets.append(shape_path)
    binding.CreateBlendShapesAttr(Vt.TokenArray([shape_tokens[(skin.object, s.name)]
                                                 for s in shapes]))
    binding.CreateBlendShapeTargetsRel().SetTargets(targets)
