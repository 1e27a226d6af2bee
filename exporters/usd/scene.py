"""SceneRecord -> a stage, laid out as docs/stage_contract.md says.

write_scene writes a whole scene and returns where it put each record (StagePaths);
the pieces it is made of (an object's prim and attributes, its mesh prim, a material)
are also what exporters/live.py writes alone, at those same paths."""
from dataclasses import dataclass, field

import numpy as np
from pxr import Gf, Sdf, UsdGeom, UsdSkel, Vt

from .camera import write_camera
from .curves import write_curves
from .instances import write_instances, write_points, write_prototype
from .light import write_ellipse_scale, write_light
from .material import write_material
from .mesh import bind_materials, write_mesh
from .names import Namer, primvar_name, set_blender_name, set_pass_index
from .skel import bind_skin, write_skeleton
from .stage import write_metadata, write_render_settings
from .world import write_world

ROOT = Sdf.Path("/root")
PROTOTYPES = ROOT.AppendChild("_prototypes")
MATERIALS = ROOT.AppendChild("_materials")
WORLD = ROOT.AppendChild("_world")


def _channel(op, values, times, convert):
    """One default value when the channel does not change, else a sample per time."""
    if len(values) == 1 or np.all(values == values[:1]):
        op.Set(convert(values[0]))
        return
    with Sdf.ChangeBlock():
        for frame, value in zip(times, values):
            op.Set(convert(value), frame)


def write_transform(prim, obj, times=()):
    """translate, orient (quaternion) and scale ops when the matrix is TRS, so that USD
    interpolates between samples as Blender does; the matrix op only for shear."""
    xformable = UsdGeom.Xformable(prim)
    if obj.trs is not None:
        precision = UsdGeom.XformOp.PrecisionDouble
        _channel(xformable.AddTranslateOp(precision), obj.trs.translations, times,
                 lambda v: Gf.Vec3d(*map(float, v)))
        _channel(xformable.AddOrientOp(precision), obj.trs.rotations, times,
                 lambda q: Gf.Quatd(float(q[3]), float(q[0]), float(q[1]), float(q[2])))
        _channel(xformable.AddScaleOp(precision), obj.trs.scales, times,
                 lambda v: Gf.Vec3d(*map(float, v)))
        return
    # Blender's matrices act on column vectors, USD's on row vectors: transpose.
    samples = obj.matrix_samples if obj.matrix_samples is not None else obj.matrix[None]
    _channel(xformable.AddTransformOp(), samples, times, lambda m: Gf.Matrix4d(m.T.tolist()))


def _bake_points(stage, mesh_path, samples):
    """Time-sampled points, normals and extent of a mesh UsdSkel cannot deform."""
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(mesh_path))
    points, normals, extent = mesh.GetPointsAttr(), mesh.GetNormalsAttr(), mesh.GetExtentAttr()
    for frame, p, n in zip(samples.times, samples.points, samples.normals):
        points.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(p)), frame)
        normals.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(n)), frame)
        lo, hi = p.min(axis=0), p.max(axis=0)
        extent.Set(Vt.Vec3fArray([tuple(map(float, lo)), tuple(map(float, hi))]), frame)


@dataclass
class StagePaths:
    """Where write_scene put each record (what a partial export needs to write the
    same prims again)."""
    objects: dict = field(default_factory=dict)     # object key -> its prim
    meshes: dict = field(default_factory=dict)      # object key -> its mesh prim
    prototypes: dict = field(default_factory=dict)  # shared mesh key -> the prototype's prim
    materials: dict = field(default_factory=dict)   # material key -> Material prim
    default_uv: dict = field(default_factory=dict)  # material key -> primvar of its textures
    skeletons: dict = field(default_factory=dict)   # rig key -> (Skeleton path, shape tokens)
    world: Sdf.Path | None = None


def double_sided(materials, slot_keys):
    """Whether a mesh with these slot materials is drawn two-sided: unless every one
    asks for backface culling. `materials`: key -> MaterialRecord."""
    mats = [materials[k] for k in slot_keys if k is not None]
    return not (mats and all(m.backface_culling for m in mats))


def slot_names(materials, slot_keys):
    return [materials[k].name if k is not None else None for k in slot_keys]


def write_material_prim(stage, path, rec, default_uv, asset_path):
    write_material(stage, path, rec, default_uv, asset_path)
    prim = stage.GetPrimAtPath(path)
    set_blender_name(prim, rec.name)
    set_pass_index(prim, rec.pass_index)


def define_object_prim(stage, path, obj):
    """The object's own prim: the UsdLux light or camera it is, a SkelRoot for a rig
    (its Skeleton is written apart), else an Xform."""
    if obj.kind == "light":
        return write_light(stage, path, obj.light).GetPrim()
    if obj.kind == "camera":
        return write_camera(stage, path, obj.camera).GetPrim()
    if obj.rig is not None:
        return UsdSkel.Root.Define(stage, path).GetPrim()
    return UsdGeom.Xform.Define(stage, path).GetPrim()


def write_object_attributes(prim, obj, times=()):
    """What an object prim holds of the object itself: its transform, Blender name
    and pass index."""
    write_transform(prim, obj, times)
    if obj.kind == "light":
        write_ellipse_scale(prim, obj.light)
    set_blender_name(prim, obj.name)
    set_pass_index(prim, obj.pass_index)


def write_object_mesh(stage, mesh_path, obj, rec, materials, paths, max_influences=None):
    """An object's mesh prim: its data (or a reference to the shared prototype), its
    material bindings, its skin and its baked points."""
    if obj.shared:
        stage.DefinePrim(mesh_path).GetReferences().AddInternalReference(
            paths.prototypes[obj.mesh])
    else:
        write_mesh(stage, mesh_path, rec, double_sided(materials, obj.materials),
                   slot_names(materials, obj.materials))
        set_blender_name(stage.GetPrimAtPath(mesh_path), rec.name)
    bind_materials(stage, mesh_path, rec, obj.materials, paths.materials)
    if rec.skin is not None:
        skeleton_path, tokens = paths.skeletons[rec.skin.rig]
        bind_skin(stage, mesh_path, rec.skin, skeleton_path, tokens, max_influences)
    if rec.point_samples is not None:
        _bake_points(stage, mesh_path, rec.point_samples)


def write_scene(stage, scene, asset_path, max_influences=None) -> StagePaths:
    namer = Namer()
    paths = StagePaths()
    for reserved in ("_prototypes", "_materials", "_world"):
        namer.reserve(ROOT, reserved)
    UsdGeom.Xform.Define(stage, ROOT)
    write_metadata(stage, scene.settings, ROOT)

    slots_of = {}  # mesh key -> slot materials of its first user (prototype subsets, sidedness)
    for obj in scene.objects:
        if obj.mesh is not None:
            slots_of.setdefault(obj.mesh, obj.materials)

    if scene.materials:
        UsdGeom.Scope.Define(stage, MATERIALS)
        for key, rec in scene.materials.items():
            default_uv = next((primvar_name(scene.meshes[o.mesh].active_uv)
                               for o in scene.objects
                               if o.mesh is not None and key in o.materials
                               and scene.meshes[o.mesh].active_uv), "UVMap")
            path = namer.child(MATERIALS, rec.name)
            write_material_prim(stage, path, rec, default_uv, asset_path)
            paths.materials[key], paths.default_uv[key] = path, default_uv

    for proto in scene.prototypes.values():
        if proto.mesh is not None:
            slots_of.setdefault(proto.mesh, proto.materials)
    shared = sorted({o.mesh for o in scene.objects if o.shared} |
                    {p.mesh for p in scene.prototypes.values() if p.mesh is not None})
    if shared or scene.prototypes:
        stage.CreateClassPrim(PROTOTYPES)
        for key in shared:
            rec = scene.meshes[key]
            path = namer.child(PROTOTYPES, rec.name)
            write_mesh(stage, path, rec, double_sided(scene.materials, slots_of[key]),
                       slot_names(scene.materials, slots_of[key]))
            set_blender_name(stage.GetPrimAtPath(path), rec.name)
            paths.prototypes[key] = path
    instance_paths = {}  # prototype key -> its Xform under /root/_prototypes
    for key in sorted(scene.prototypes):
        proto = scene.prototypes[key]
        instance_paths[key] = namer.child(PROTOTYPES, proto.name)
        write_prototype(stage, instance_paths[key], proto, paths.prototypes, paths.materials,
                        scene.meshes)

    for obj in scene.objects:
        parent = paths.objects[obj.parent] if obj.parent is not None else ROOT
        path = namer.child(parent, obj.name)
        paths.objects[obj.key] = path
        prim = define_object_prim(stage, path, obj)
        if obj.rig is not None:
            paths.skeletons[obj.rig] = write_skeleton(stage, path, scene.skeletons[obj.rig], namer)
        write_object_attributes(prim, obj, scene.times)
        if obj.points is not None:
            write_points(stage, namer.child(path, obj.points.name), obj.points)
        for curves in obj.curves:
            material = paths.materials.get(obj.materials[0]) if obj.materials else None
            write_curves(stage, namer.child(path, curves.name), curves, material)
        if obj.instances is not None:
            write_instances(stage, namer.child(path, "Instances"), obj.instances,
                            instance_paths, namer)
        if obj.kind != "mesh":
            continue
        rec = scene.meshes[obj.mesh]
        mesh_path = namer.child(path, rec.name)
        paths.meshes[obj.key] = mesh_path
        write_object_mesh(stage, mesh_path, obj, rec, scene.materials, paths, max_influences)

    if scene.world is not None:
        write_world(stage, WORLD, scene.world, asset_path)
        paths.world = WORLD
    camera = paths.objects.get(scene.settings.camera)
    write_render_settings(stage, scene.settings, camera)
    return paths
