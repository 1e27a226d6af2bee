"""Shared helpers for the procedural export tests."""
import bpy
import numpy as np
from pxr import Usd

from lantern.exporters import export_depsgraph, validation_errors

CUBE_VERTS = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
CUBE_FACES = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]


def cube_object(name, mesh=None):
    if mesh is None:
        mesh = bpy.data.meshes.new(name + "_mesh")
        mesh.from_pydata(CUBE_VERTS, [], CUBE_FACES)
        mesh.update()
    ob = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def export_current(options=None, path=None):
    """Exports the current scene into a new stage (in memory unless `path`)."""
    bpy.context.view_layer.update()
    stage = Usd.Stage.CreateNew(str(path)) if path else Usd.Stage.CreateInMemory()
    report = export_depsgraph(bpy.context.evaluated_depsgraph_get(), stage, options)
    assert validation_errors(stage) == []
    return stage, report


def evaluated_mesh_data(ob, fn):
    deps = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(deps)
    mesh = ev.to_mesh()
    try:
        return fn(mesh)
    finally:
        ev.to_mesh_clear()


def vectors(collection, attr="vector", width=3):
    out = np.empty(len(collection) * width, dtype=np.float32)
    collection.foreach_get(attr, out)
    return out.reshape(-1, width)


def skinned_stage(stage):
    """A copy of `stage` with UsdSkel's own skinning baked into the meshes' points."""
    from pxr import Gf, UsdSkel
    copy = Usd.Stage.CreateInMemory()
    copy.GetRootLayer().TransferContent(stage.GetRootLayer())
    assert UsdSkel.BakeSkinning(copy.Traverse(), Gf.Interval(stage.GetStartTimeCode(),
                                                             stage.GetEndTimeCode()))
    return copy


def usd_world_points(stage, object_path, frame):
    """World-space points of the Mesh under an object prim at a time code."""
    from pxr import Gf, UsdGeom
    prim = stage.GetPrimAtPath(object_path)
    meshes = [c for c in prim.GetChildren() if c.IsA(UsdGeom.Mesh)]
    assert len(meshes) == 1, object_path
    mesh = UsdGeom.Mesh(meshes[0])
    points = np.array(mesh.GetPointsAttr().Get(frame), dtype=np.float64)
    m = np.array(mesh.ComputeLocalToWorldTransform(frame))  # row-vector convention
    return points @ m[:3, :3] + m[3, :3]


def blender_world_points(ob):
    """World-space vertices of the evaluated object at the current frame."""
    deps = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(deps)
    mesh = ev.to_mesh()
    try:
        co = vectors(mesh.vertices, "co").astype(np.float64)
    finally:
        ev.to_mesh_clear()
    m = np.array(ev.matrix_world)
    return co @ m[:3, :3].T + m[:3, 3]


def object_paths(stage):
    """Blender object name -> prim path of every exported object prim."""
    from pxr import UsdGeom
    return {p.GetAttribute("lantern:blenderName").Get(): p.GetPath()
            for p in stage.Traverse() if p.HasAttribute("lantern:blenderName")
            and not p.IsA(UsdGeom.Mesh) and not p.GetPath().pathString.startswith("/root/_")}


def parity(stage, objects, frames=None):
    """Largest |UsdSkel-skinned − Blender| per object over `frames` (default: the
    stage's range), as a fraction of the object's Blender bounding-box diagonal."""
    scene = bpy.context.scene
    frames = frames if frames is not None else range(scene.frame_start, scene.frame_end + 1)
    baked = skinned_stage(stage)
    paths = object_paths(stage)
    worst = {ob.name: 0.0 for ob in objects}
    current = scene.frame_current
    try:
        for f in frames:
            scene.frame_set(f)
            for ob in objects:
                expected = blender_world_points(ob)
                got = usd_world_points(baked, paths[ob.name], f)
                assert got.shape == expected.shape, (ob.name, f)
                diag = float(np.linalg.norm(expected.max(0) - expected.min(0))) or 1.0
                worst[ob.name] = max(worst[ob.name], float(np.abs(got - expected).max()) / diag)
    finally:
        scene.frame_set(current)
    return worst


def make_armature(name="Rig", bone_names=("Bone0", "Bone1", "Bone2"), length=1.0,
                  roll=0.4, chain=True):
    """An armature whose bones run up +Z one after another (rolled a little each)."""
    data = bpy.data.armatures.new(name + "_data")
    arm = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    previous = None
    for i, bone_name in enumerate(bone_names):
        eb = data.edit_bones.new(bone_name)
        eb.head, eb.tail = (0.1 * i, 0, i * length), (0.1 * i, 0.05, (i + 1) * length)
        eb.roll = roll * (i + 1)
        if chain and previous is not None:
            eb.parent = previous
        previous = eb
    bpy.ops.object.mode_set(mode="OBJECT")
    return arm


def make_tube(name, height=3.0, rings=13, segments=8, radius=0.3):
    """A closed-side tube along +Z: rings × segments vertices, quads."""
    verts = [(radius * np.cos(2 * np.pi * s / segments), radius * np.sin(2 * np.pi * s / segments),
              height * r / (rings - 1)) for r in range(rings) for s in range(segments)]
    faces = [(r * segments + s, r * segments + (s + 1) % segments,
              (r + 1) * segments + (s + 1) % segments, (r + 1) * segments + s)
             for r in range(rings - 1) for s in range(segments)]
    mesh = bpy.data.meshes.new(name + "_mesh")
    mesh.from_pydata([tuple(map(float, v)) for v in verts], [], faces)
    mesh.update()
    ob = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def weight_by_height(ob, bone_names, length=1.0, spread=1.0, skip=()):
    """Smooth weights: each vertex to every bone, falling off with distance along Z.
    Vertices whose index is in `skip` get no groups."""
    groups = [ob.vertex_groups.new(name=n) for n in bone_names]
    for v in ob.data.vertices:
        if v.index in skip:
            continue
        for i, g in enumerate(groups):
            d = abs(v.co.z - (i + 0.5) * length) / (spread * length)
            w = max(0.0, 1.0 - d)
            if w > 0:
                g.add([v.index], w, "REPLACE")


def add_armature_modifier(ob, arm, preserve_volume=False):
    mod = ob.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    mod.use_deform_preserve_volume = preserve_volume
    return mod


def animate_pose(arm, frames=range(1, 6), scale=None, translate=True):
    """Keys rotations (and root translation, optional bone scales) on every bone."""
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = frames[0], frames[-1]
    for f in frames:
        for i, pb in enumerate(arm.pose.bones):
            pb.rotation_mode = "XYZ"
            pb.rotation_euler = (0.3 * np.sin(f + i), 0.25 * f * (i + 1) / 5, -0.2 * np.cos(f))
            pb.keyframe_insert("rotation_euler", frame=f)
            if translate and i == 0:
                pb.location = (0.1 * f, -0.05 * f, 0.02 * f)
                pb.keyframe_insert("location", frame=f)
            if scale is not None:
                pb.scale = scale(f, i)
                pb.keyframe_insert("scale", frame=f)
    scene.frame_set(frames[0])
