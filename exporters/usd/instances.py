"""PrototypeRecord, InstancesRecord and PointsRecord -> prototypes under the class prim
/root/_prototypes, a UsdGeom.PointInstancer per instancer, and UsdGeom.Points
(docs/stage_contract.md, "Instances and points")."""
import numpy as np
from pxr import Gf, Sdf, UsdGeom, Vt

from .mesh import bind_materials
from .names import set_blender_name


def write_points(stage, path, rec):
    points = UsdGeom.Points.Define(stage, path)
    points.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rec.points)))
    points.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.ascontiguousarray(rec.widths)))
    points.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    radius = rec.widths[:, None] / 2 if len(rec.widths) else np.zeros((0, 1))
    if len(rec.points):
        lo, hi = (rec.points - radius).min(axis=0), (rec.points + radius).max(axis=0)
        points.CreateExtentAttr(Vt.Vec3fArray([tuple(map(float, lo)), tuple(map(float, hi))]))
    set_blender_name(points.GetPrim(), rec.name)
    return points


def write_prototype(stage, path, proto, mesh_paths, material_paths, meshes):
    """An Xform (identity) holding the prototype's geometry: a Mesh referencing the data
    written once in /root/_prototypes, with this object's material slots, or Points."""
    prim = UsdGeom.Xform.Define(stage, path).GetPrim()
    set_blender_name(prim, proto.name)
    if proto.points is not None:
        write_points(stage, path.AppendChild("Points"), proto.points)
        return
    rec = meshes[proto.mesh]
    mesh_path = path.AppendChild(Sdf.Path(mesh_paths[proto.mesh]).name)
    stage.DefinePrim(mesh_path).GetReferences().AddInternalReference(mesh_paths[proto.mesh])
    bind_materials(stage, mesh_path, rec, proto.materials, material_paths)


def write_instances(stage, path, rec, proto_paths, namer):
    """A PointInstancer at `path` for the instances that are translate · orient · scale;
    an instance whose matrix shears is an instanceable Xform with that matrix,
    referencing its prototype, beside it."""
    exact = rec.exact
    instancer = UsdGeom.PointInstancer.Define(stage, path)
    instancer.CreatePrototypesRel().SetTargets([proto_paths[k] for k in rec.prototypes])
    trs = rec.trs
    instancer.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(
        np.ascontiguousarray(rec.proto_indices[exact], np.int32)))
    instancer.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(
        np.ascontiguousarray(trs.translations[exact], np.float32)))
    # orientationsf (float) rather than orientations (half): half precision would turn
    # an instance by up to 1e-3 radians.
    instancer.CreateOrientationsfAttr(Vt.QuatfArray.FromNumpy(
        np.ascontiguousarray(trs.rotations[exact], np.float32)))
    instancer.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(
        np.ascontiguousarray(trs.scales[exact], np.float32)))
    extent = instancer.ComputeExtentAtTime(0.0, 0.0)
    if extent is not None and len(extent) == 2:
        instancer.CreateExtentAttr(extent)
    parent = path.GetParentPath()
    for i in np.flatnonzero(~exact):
        prim = UsdGeom.Xform.Define(stage, namer.child(parent, f"{path.name}_sheared")).GetPrim()
        UsdGeom.Xformable(prim).AddTransformOp().Set(Gf.Matrix4d(rec.matrices[i].T.tolist()))
        prim.GetReferences().AddInternalReference(proto_paths[rec.prototypes[rec.proto_indices[i]]])
        prim.SetInstanceable(True)
    return instancer
