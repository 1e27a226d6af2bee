"""Live exports: the scene at the current frame, kept up to date piece by piece.

`export_live` writes the whole scene at the current frame only (rigs as UsdSkel with
that frame's pose: no frame range is sampled) and returns a LiveIndex, what the
partial exports need to write again at the same paths:

    export_object(depsgraph, stage, index, key)     its transform and pass index
    export_geometry(depsgraph, stage, index, key)   its mesh, re-exported alone
    export_material(depsgraph, stage, index, key)   one material
    export_data(depsgraph, stage, index, key)       a light's or camera's prim
    export_world(depsgraph, stage, index)           the world's dome
    export_pose(depsgraph, stage, index, rig)       a rig's joints and blend-shape
                                                    weights at the current frame

Each gathers with the full export's gatherers and writes with its writers into a
scratch stage, then copies what it wrote into `stage` with Sdf.CopySpec, which
changes only the fields that differ: rewriting a prim whose values did not change
changes nothing, and what did change is all that USD reports (see
engine/usd/fragments.py, which sends exactly that to the engine). An edit that
changes the stage's structure (a new material, a mesh no longer shared, a skinned
mesh's rest shape) raises NeedsFullExport; the caller exports the scene again.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import bpy
import numpy as np
from pxr import Sdf, Usd, UsdShade

from .errors import require_finite
from .gather.camera import gather_camera
from .gather.light import gather_light
from .gather.material import gather_material
from .gather.scene import gather_geometry, gather_scene, is_shareable
from .gather.shapes import shape_weights
from .gather.skeleton import (decompose, local_matrices, pose_index, pose_matrices,
                              relative_matrix, trs)
from .gather.skin import animated
from .gather.subdivision import data_cage
from .gather.tangents import tangent_uv_map
from .gather.world import gather_world
from .ir import ObjectRecord, SceneRecord
from .usd.assets import asset_resolver
from .usd.mesh import write_mesh
from .usd.names import set_blender_name
from .usd.scene import (WORLD, define_object_prim, double_sided, slot_names,
                        write_material_prim, write_object_attributes, write_object_mesh,
                        write_scene)
from .usd.skel import joint_paths, write_animation
from .usd.world import write_world


class NeedsFullExport(Exception):
    """The edit changes the stage's structure: export the whole scene again."""


@dataclass
class LiveIndex:
    """What a live export wrote, for the partial exports that follow it."""
    frame: int
    paths: object                                   # usd.scene.StagePaths
    objects: dict = field(default_factory=dict)     # object key -> ObjectRecord (no arrays)
    parents: dict = field(default_factory=dict)     # object key -> Blender parent name
    meshes: dict = field(default_factory=dict)      # mesh key -> (name, active UV, baked)
    materials: dict = field(default_factory=dict)   # material key -> MaterialRecord
    tangent_uv: dict = field(default_factory=dict)  # material key -> its normal map's UV
    skeletons: dict = field(default_factory=dict)   # rig key -> SkeletonRecord
    bones: dict = field(default_factory=dict)       # armature key -> its bones' rest
    rig_of: dict = field(default_factory=dict)      # skinned or blend-shaped object -> rig
    shared_data: set = field(default_factory=set)   # mesh data names written as prototypes
    moving: set = field(default_factory=set)        # objects a frame change may move
    world: str | None = None                        # the world's name
    settings: tuple = ()                            # what else a full export depends on
    subdivision: str = "apply"                      # ExportOptions.subdivision
    cages: set = field(default_factory=set)         # mesh keys written as subdivision cages

    @property
    def baked(self) -> list:
        """Objects whose deformation is written as points (re-exported per frame)."""
        return [k for k, o in self.objects.items()
                if o.mesh is not None and self.meshes[o.mesh][2]]


def settings_key(scene) -> tuple:
    """Scene settings the stage holds outside any object (a change needs a full
    export): units, frame rate and range, resolution, the active camera, the world."""
    r = scene.render
    return (scene.unit_settings.scale_length, r.fps, r.fps_base, scene.frame_start,
            scene.frame_end, r.resolution_x, r.resolution_y, r.resolution_percentage,
            r.pixel_aspect_x, r.pixel_aspect_y,
            scene.camera.name_full if scene.camera else None,
            scene.world.name_full if scene.world else None)


def export_live(depsgraph, stage, warn, subdivision="apply") -> LiveIndex:
    """The whole scene at the current frame into `stage` (its root layer's content is
    replaced; USD reports only what differs from what it held). `subdivision`:
    "cage" writes a mesh whose data is its subdivision cage as that cage, so that its
    edits send the cage (gather/subdivision.py data_cage)."""
    scene = depsgraph.scene
    frame = scene.frame_current
    rec = gather_scene(depsgraph, warn, None, animation=True, live=True,
                       subdivision=subdivision)
    scratch = Usd.Stage.CreateInMemory()
    paths = write_scene(scratch, rec, asset_resolver(None))
    stage.GetRootLayer().TransferContent(scratch.GetRootLayer())
    index = LiveIndex(frame=frame, paths=paths, settings=settings_key(scene),
                      world=scene.world.name_full if scene.world else None,
                      subdivision=subdivision,
                      cages={k for k, m in rec.meshes.items() if m.subdivision is not None})
    for obj in rec.objects:
        index.objects[obj.key] = copy.copy(obj)
        index.objects[obj.key].points = index.objects[obj.key].instances = None
        original = bpy.data.objects.get(obj.key)
        index.parents[obj.key] = original.parent.name_full if original and original.parent else None
        if obj.rig is not None:
            index.rig_of[obj.key] = obj.rig
        if obj.shared:
            index.shared_data.add(obj.mesh.removeprefix("proto:"))
    for key, mesh in rec.meshes.items():
        index.meshes[key] = (mesh.name, mesh.active_uv, mesh.point_samples is not None)
        if mesh.skin is not None:
            index.rig_of[mesh.skin.object] = mesh.skin.rig
    index.materials = dict(rec.materials)
    for key in rec.materials:
        material = bpy.data.materials.get(key)
        index.tangent_uv[key] = tangent_uv_map([material]) if material else None
    for key, skel in rec.skeletons.items():
        for name in skel.blend_shapes:
            index.rig_of.setdefault(name[0], key)
        index.skeletons[key] = skel
        if skel.joint_names:
            index.bones[key] = _bones(_original(key))
    index.moving = _moving(index)
    return index


def _moving(index) -> set:
    """Objects whose transform a frame change may move: animated, constrained, driven
    or bone-parented, or under one that is."""
    moving = set()
    for key in index.objects:                     # parents come before children
        ob = bpy.data.objects.get(key)
        if ob is None:
            continue
        parent = index.parents.get(key)
        if animated(ob) or len(ob.constraints) or ob.parent_type == "BONE" or \
                (parent is not None and parent in moving):
            moving.add(key)
    return moving


# --- partial exports ------------------------------------------------------------------

def _original(key, kind="objects"):
    found = getattr(bpy.data, kind).get(key)
    if found is None:
        raise NeedsFullExport(f"{key} is no longer in bpy.data.{kind}")
    return found


def _bones(armature):
    """An armature's bones as they rest: names and armature-space matrices (a change
    of either is a new skeleton, so a full export)."""
    bones = armature.data.bones
    rest = np.empty(len(bones) * 16, np.float32)
    bones.foreach_get("matrix_local", rest)
    return [b.name for b in bones], rest


def _world_matrix(depsgraph, key) -> np.ndarray:
    return np.array(_original(key).evaluated_get(depsgraph).matrix_world, dtype=np.float64)


def _object_now(depsgraph, index, key):
    """(the object's record with its current local matrix, name and pass index,
    whether any of those changed since the record was made)."""
    if key not in index.objects:
        raise NeedsFullExport(f"object {key} is not in the stage")
    ob = _original(key)
    old = index.objects[key]
    world = _world_matrix(depsgraph, key)
    require_finite(world, f"object '{ob.name}'", "transform")
    local = relative_matrix(_world_matrix(depsgraph, old.parent), world) \
        if old.parent is not None else world
    if np.array_equal(local, old.matrix) and (ob.name, ob.pass_index) == \
            (old.name, old.pass_index) and old.trs is not None and len(old.trs.rotations) == 1:
        return old, False
    obj = copy.copy(old)
    obj.matrix, obj.matrix_samples, obj.trs = local, None, trs(local[None])
    obj.name, obj.pass_index = ob.name, int(ob.pass_index)
    index.objects[key] = obj
    return obj, True


def _copy_properties(src, dst, src_path, dst_path=None):
    """Every property of the prim at src_path in scratch layer `src` onto the prim at
    dst_path in `dst` (its other properties and its children stay)."""
    dst_path = Sdf.Path(dst_path or src_path)
    for prop in src.GetPrimAtPath(src_path).properties:
        Sdf.CopySpec(src, prop.path, dst, dst_path.AppendProperty(prop.name))


def _copy_prim(src, dst, path):
    """A prim's own fields (type, applied schemas) and properties, not its children;
    properties it no longer has are removed."""
    spec, target = src.GetPrimAtPath(path), dst.GetPrimAtPath(path)
    for key in spec.ListInfoKeys():
        if target.GetInfo(key) != spec.GetInfo(key):
            target.SetInfo(key, spec.GetInfo(key))
    for key in set(target.ListInfoKeys()) - set(spec.ListInfoKeys()):
        target.ClearInfo(key)
    names = {p.name for p in spec.properties}
    for prop in list(target.properties):
        if prop.name not in names:
            target.RemoveProperty(prop)
    _copy_properties(src, dst, path)


def export_object(depsgraph, stage, index, key):
    """The object's transform (relative to its exported parent), name and pass index;
    False (nothing written) when none changed."""
    obj, changed = _object_now(depsgraph, index, key)
    if not changed:
        return False
    path = index.paths.objects[key]
    scratch = Usd.Stage.CreateInMemory()
    write_object_attributes(scratch.OverridePrim(path), obj)
    with Sdf.ChangeBlock():
        _copy_properties(scratch.GetRootLayer(), stage.GetRootLayer(), path)
    return True


def export_data(depsgraph, stage, index, key, warn):
    """A light's or a camera's prim (the object prim is the UsdLux light or the
    camera), with its transform; its children stay."""
    obj, _ = _object_now(depsgraph, index, key)
    ob = _original(key)
    if obj.kind == "light" and ob.type == "LIGHT":
        obj.light = gather_light(ob.data, warn)
    elif obj.kind == "camera" and ob.type == "CAMERA":
        obj.camera = gather_camera(ob.data, depsgraph.scene.render, warn)
    else:
        raise NeedsFullExport(f"object {key} changed type")
    path = index.paths.objects[key]
    scratch = Usd.Stage.CreateInMemory()
    write_object_attributes(define_object_prim(scratch, path, obj), obj)
    with Sdf.ChangeBlock():
        _copy_prim(scratch.GetRootLayer(), stage.GetRootLayer(), path)


def export_geometry(depsgraph, stage, index, key, warn):
    """The object's evaluated mesh, re-exported alone with its material bindings (the
    shared prototype when its data is shared). Skinned meshes are not re-exported
    here: their rest shape is a full export's business."""
    obj = index.objects.get(key)
    if obj is None or obj.kind != "mesh":
        raise NeedsFullExport(f"object {key} is not a mesh in the stage")
    if key in index.rig_of and not index.meshes[obj.mesh][2]:
        raise NeedsFullExport(f"object {key} is skinned: its rest mesh changed")
    ob = _original(key)
    shared = {ob.data.name_full} & index.shared_data if is_shareable(ob) else set()
    rec = SceneRecord()
    fresh = ObjectRecord(key=key, name=ob.name, parent=obj.parent, matrix=obj.matrix,
                         kind="empty")
    cage = data_cage(ob, depsgraph) if index.subdivision == "cage" else None
    if (cage is not None) != (obj.mesh in index.cages):
        raise NeedsFullExport(f"object {key}: its subdivision is no longer written as it was")
    gather_geometry(ob.evaluated_get(depsgraph), fresh, rec, shared, None, {}, warn, cage,
                    cage_from_data=True)
    if fresh.mesh != obj.mesh or fresh.mesh not in rec.meshes:
        raise NeedsFullExport(f"object {key}: its mesh is no longer written as it was")
    slots = [m[0] if m else None for m in fresh.materials]
    if any(k is not None and k not in index.paths.materials for k in slots):
        raise NeedsFullExport(f"object {key} uses a material the stage lacks")
    fresh.materials = slots
    mesh = rec.meshes[fresh.mesh]
    scratch = Usd.Stage.CreateInMemory()
    for material in {k for k in slots if k is not None}:   # what the bindings target
        UsdShade.Material.Define(scratch, index.paths.materials[material])
    if fresh.shared:
        path = index.paths.prototypes[fresh.mesh]
        write_mesh(scratch, path, mesh, double_sided(index.materials, slots),
                   slot_names(index.materials, slots))
        set_blender_name(scratch.GetPrimAtPath(path), mesh.name)
    else:
        path = index.paths.meshes[key]
        write_object_mesh(scratch, path, fresh, mesh, index.materials, index.paths)
    obj.materials = slots
    with Sdf.ChangeBlock():
        Sdf.CopySpec(scratch.GetRootLayer(), path, stage.GetRootLayer(), path)


def export_material(depsgraph, stage, index, key, warn):
    """One material, at its path. A change of sidedness or of normal mapping changes
    its meshes too (double-sidedness, tangents): that is a full export."""
    if key not in index.paths.materials:
        raise NeedsFullExport(f"material {key} is not in the stage")
    material = _original(key, "materials")
    rec = gather_material(material, warn)
    if rec.backface_culling != index.materials[key].backface_culling or \
            tangent_uv_map([material]) != index.tangent_uv.get(key):
        raise NeedsFullExport(f"material {key} changes its meshes")
    path = index.paths.materials[key]
    scratch = Usd.Stage.CreateInMemory()
    write_material_prim(scratch, path, rec, index.paths.default_uv[key], asset_resolver(None))
    index.materials[key] = rec
    with Sdf.ChangeBlock():
        Sdf.CopySpec(scratch.GetRootLayer(), path, stage.GetRootLayer(), path)


def export_world(depsgraph, stage, index, warn):
    world = depsgraph.scene.world
    if (world.name_full if world else None) != index.world or index.paths.world is None:
        raise NeedsFullExport("the scene's world changed")
    scratch = Usd.Stage.CreateInMemory()
    write_world(scratch, WORLD, gather_world(world, warn), asset_resolver(None))
    with Sdf.ChangeBlock():
        Sdf.CopySpec(scratch.GetRootLayer(), WORLD, stage.GetRootLayer(), WORLD)


def export_pose(depsgraph, stage, index, rig):
    """A rig's SkelAnimation at the current frame: joint translations, rotations and
    scales, and blend-shape weights; nothing else of the rig."""
    skel = copy.copy(index.skeletons[rig])
    frame = depsgraph.scene.frame_current
    if skel.joint_names:
        arm = _original(rig)
        names, rest = _bones(arm)
        if names != index.bones[rig][0] or not np.array_equal(rest, index.bones[rig][1]):
            raise NeedsFullExport(f"armature {rig}: its bones changed")
        poses = pose_matrices(arm.evaluated_get(depsgraph), pose_index(arm, skel.joint_names))
        require_finite(poses, f"armature '{arm.name}'", "bone poses")
        skel.translations, skel.rotations, skel.scales, _, _ = \
            decompose(local_matrices(poses[None], skel.parents))
    if skel.blend_shapes:
        weights = [shape_weights(_original(mesh).evaluated_get(depsgraph), [name])[0]
                   for mesh, name in skel.blend_shapes]
        skel.blend_weights = np.array(weights, dtype=np.float64)[None]
        skel.blend_shapes = list(skel.blend_shapes)
    skel.times = [frame]
    path = index.paths.skeletons[rig][0].AppendChild("Animation")
    scratch = Usd.Stage.CreateInMemory()
    write_animation(scratch, path, skel, joint_paths(skel))
    with Sdf.ChangeBlock():
        _copy_properties(scratch.GetRootLayer(), stage.GetRootLayer(), path)
