"""The evaluated depsgraph -> SceneRecord."""
import os
import re

import numpy as np

from ...core.passes import asked_by

from ..errors import require_finite
from ..ir import ObjectRecord, SceneRecord, StageSettings
from .animation import Sampler, modifiers_disabled
from .camera import gather_camera
from .curves import gather_curves
from .instances import (MESH_LIKE, UNSUPPORTED, InstanceGatherer, faceless_warning,
                        particle_points, pointcloud_points, unsupported_warning)
from .light import gather_light
from .material import gather_material
from .mesh import color_attribute_names, gather_mesh
from .skeleton import relative_matrix, trs
from .subdivision import data_cage, subdivision_record, trailing_subdivision
from .tangents import mikktspace_tangents, tangent_uv_map
from .skin import animated, classify, group_entries
from .world import gather_world


def render_visible(view_layer):
    """Names of objects in collections that are neither excluded nor hidden for render."""
    names = set()

    def walk(layer_collection):
        if layer_collection.exclude or layer_collection.collection.hide_render:
            return
        names.update(ob.name_full for ob in layer_collection.collection.objects)
        for child in layer_collection.children:
            walk(child)

    walk(view_layer.layer_collection)
    return names


def colour_management(scene) -> tuple:
    """(view transform, look or None, exposure): Render Properties > Color Management,
    which display images are made with. Blender names the absence of a look "None"."""
    view = scene.view_settings
    return (view.view_transform, None if view.look in ("None", "NONE", "") else view.look,
            float(view.exposure))


def _settings(scene, warn):
    r = scene.render
    pct = r.resolution_percentage / 100.0
    view, device = scene.view_settings, scene.display_settings.display_device
    view_transform, look, exposure = colour_management(scene)
    ignored = [what for what, differs in ((f"display device {device!r}", device != "sRGB"),
                                          (f"gamma {view.gamma:g}", view.gamma != 1.0),
                                          ("curves", view.use_curve_mapping)) if differs]
    if ignored:
        warn(f"scene '{scene.name}': colour management's {', '.join(ignored)} not "
             "exported; display images are made for sRGB without them")
    return StageSettings(
        fps=r.fps / r.fps_base, frame_start=scene.frame_start, frame_end=scene.frame_end,
        meters_per_unit=float(scene.unit_settings.scale_length) or 1.0,
        resolution=(max(1, int(r.resolution_x * pct)), max(1, int(r.resolution_y * pct))),
        pixel_aspect=float(r.pixel_aspect_x / r.pixel_aspect_y),
        view_transform=view_transform, look=look, exposure=exposure, **light_paths(scene))


def light_paths(scene) -> dict:
    """Cycles' Light Paths bounces (StageSettings fields); Cycles' defaults where the
    Cycles add-on, which owns them, is not enabled."""
    cycles = getattr(scene, "cycles", None)
    if cycles is None:
        return {}
    return {"max_bounces": int(cycles.max_bounces),
            "diffuse_bounces": int(cycles.diffuse_bounces),
            "glossy_bounces": int(cycles.glossy_bounces)}


def product_name(filepath: str) -> str:
    """Blender's output path as a RenderProduct's productName, naming the files
    Blender's Render Animation writes: `//` (the .blend's folder) becomes a path
    relative to the working folder (husk's rule for a relative productName), a run of
    '#' the $F token of its width, a name without '#' gets Blender's four digits, and
    the file is a multi-layer .exr."""
    path = filepath[2:] if filepath.startswith("//") else filepath
    folder, name = os.path.split(path)
    name = re.sub(r"\.exr$", "", name, flags=re.I)
    name = re.sub(r"#+", lambda m: f"$F{len(m.group(0))}", name) if "#" in name \
        else name + "$F4"
    return os.path.join(folder, name + ".exr")


def render_passes(depsgraph, settings):
    """The view layer's render passes and output into the stage settings."""
    layer = depsgraph.view_layer
    settings.view_layer = layer.name
    settings.render_passes = tuple(asked_by(layer))
    settings.output = product_name(depsgraph.scene.render.filepath)


def is_shareable(ob):
    """True when the evaluated mesh is exactly the mesh data, so objects can share it."""
    return ob.type == "MESH" and len(ob.modifiers) == 0 and ob.data.shape_keys is None


def _animated_scene(scene):
    """True when anything may move over the frame range: sampling is worth it."""
    for ob in scene.objects:
        keys = ob.data.shape_keys if ob.type == "MESH" else None
        if ob.type == "ARMATURE" or animated(ob) or animated(ob.data) or animated(keys):
            return True
    return False


def _ancestors(ob):
    while ob.parent is not None:
        ob = ob.parent
        yield ob


def gather_scene(depsgraph, warn, texture_dir=None, animation=True, live=False,
                 subdivision="apply"):
    """`animation`: sample the frame range (rigs, blend shapes, moving objects). Only a
    viewport depsgraph can step through frames; a render one is exported as a still.
    `live` (the viewport, exporters/live.py): rigs at the current frame only, and no
    modifier is switched off (that would be an edit inside a depsgraph update): a
    skinned mesh's rest shape is its mesh data, so one with other modifiers than its
    Armature modifier is baked instead.
    `subdivision` (core/subdivision_modes.py): "apply" writes a Subdivision Surface
    modifier's result; "cage" writes the cage of a mesh whose last modifier is
    Catmull-Clark subdivision, with its rules (a rigged mesh's too, skinned at rest, when
    its subdivision follows its Armature modifier directly); "ignore" writes that cage
    as a polygon mesh, without the rules. Live, where no modifier may be switched off,
    only a mesh whose data is its cage (gather/subdivision.py data_cage) is written as one."""
    scene = depsgraph.scene
    rec = SceneRecord(settings=_settings(scene, warn))
    render_passes(depsgraph, rec.settings)
    visible = render_visible(depsgraph.view_layer)

    originals, shown, materials = {}, {}, {}
    instances = InstanceGatherer(rec, warn, is_shareable, materials)

    def exported(ob):
        return ob.name_full in visible and not ob.hide_render

    for inst in depsgraph.object_instances:
        if inst.is_instance:
            if exported(inst.parent.original):
                instances.add(inst)
            continue
        orig = inst.object.original
        if exported(orig):
            originals[orig.name_full] = orig
            shown[orig.name_full] = inst.show_self
    animate = animation and depsgraph.mode == "VIEWPORT" and _animated_scene(scene)
    cages = {}
    if subdivision in ("cage", "ignore"):
        find = data_cage if live else trailing_subdivision
        for key in sorted(originals):
            mod = find(originals[key], depsgraph)
            if mod is not None:
                cages[key] = mod
    rigs = {}
    if animate:
        for key in sorted(originals):
            ob = originals[key]
            if ob.type == "MESH":
                rig = classify(ob, originals, cages.get(key))
                if rig is not None and rig.armature is not None and rig.reason is None \
                        and ob in _ancestors(rig.armature):
                    rig.reason, rig.disabled = "its armature is parented to the mesh", []
                if live and rig is not None and rig.reason is None and rig.disabled:
                    if [m for m in ob.modifiers if m.show_viewport] != rig.disabled:
                        rig.reason = "other modifiers than its Armature modifier (live viewport)"
                    rig.disabled, rig.rest_from_data = [], rig.reason is None
                if rig is not None:
                    rigs[key] = rig

    # A rig UsdSkel cannot express is baked, with its subdivision applied.
    cages = {key: mod for key, mod in cages.items()
             if key not in rigs or rigs[key].reason is None}

    # Skinned meshes are written at rest: their Armature modifiers are off while the
    # meshes are read (and while sampling, which then skips Blender's skinning).
    # Subdivided meshes are read as their cages likewise.
    off = [m for r in rigs.values() for m in r.disabled] + \
        ([] if live else list(cages.values()))
    with modifiers_disabled(off, depsgraph):
        evaluated = {k: ob.evaluated_get(depsgraph) for k, ob in originals.items()}
        groups = _gather_objects(depsgraph, rec, evaluated, rigs, warn, texture_dir,
                                 instances, shown, materials, cages, live,
                                 rules=subdivision == "cage")
        if animate:
            sampler = Sampler(depsgraph, rec, originals, rigs, warn)
            sampler.build_skeletons()
            sampler.build_skins(groups)
            times = [scene.frame_current] if live else \
                list(range(scene.frame_start, scene.frame_end + 1))
            rec.times = times
            sampler.sample(times)
            sampler.write_transforms()
            sampler.write_skeletons()
    if animate:
        sampler.bake(times)
    for obj in rec.objects:
        obj.trs = trs(obj.matrix_samples if obj.matrix_samples is not None else obj.matrix[None])
    return rec


def _gather_objects(depsgraph, rec, evaluated, rigs, warn, texture_dir, instances, shown,
                    material_keys, cages, live, rules):
    scene = depsgraph.scene

    def exported_parent(orig):
        rig = rigs.get(orig.name_full)
        if rig is not None and rig.armature is not None and rig.reason is None:
            return rig.armature  # a skinned mesh lives under its rig's SkelRoot
        parent = orig.parent
        while parent is not None and parent.name_full not in evaluated:
            parent = parent.parent
        return parent

    shared_users = {}
    for ob in evaluated.values():
        if is_shareable(ob.original):
            shared_users.setdefault(ob.original.data.name_full, []).append(ob)
    shared = {k for k, users in shared_users.items() if len(users) > 1}
    shared |= instances.shared_data  # prototypes of instances hold it once already

    children = {}
    for key, ob in evaluated.items():
        parent = exported_parent(ob.original)
        children.setdefault(parent.name_full if parent else None, []).append(key)

    order = []

    def visit(parent_key):
        for key in sorted(children.get(parent_key, [])):
            order.append((key, parent_key))
            visit(key)
    visit(None)

    groups = {}  # skinned mesh key -> vertex group assignments of its rest mesh
    for key, parent_key in order:
        ob = evaluated[key]
        world = np.array(ob.matrix_world, dtype=np.float64)
        require_finite(world, f"object '{ob.original.name}'", "transform")
        if parent_key is not None:
            parent_world = np.array(evaluated[parent_key].matrix_world, dtype=np.float64)
            local = relative_matrix(parent_world, world)
        else:
            local = world
        obj = ObjectRecord(key=key, name=ob.original.name, parent=parent_key,
                           matrix=local, kind="empty", pass_index=int(ob.original.pass_index))
        if ob.type == "LIGHT":
            obj.kind, obj.light = "light", gather_light(ob.data.original, warn)
        elif ob.type == "CAMERA":
            obj.kind = "camera"
            obj.camera = gather_camera(ob.data.original, scene.render, warn)
        elif ob.type in MESH_LIKE and shown[key]:
            gather_geometry(ob, obj, rec, shared, rigs.get(key), groups, warn, cages.get(key),
                            cage_from_data=live, rules=rules)
            for mat in obj.materials:
                if mat is not None:
                    material_keys.setdefault(mat[0], mat[1])
            obj.materials = [m[0] if m else None for m in obj.materials]
        elif ob.type == "POINTCLOUD" and shown[key]:
            obj.points = pointcloud_points(ob.data, ob.data.name)
            require_finite(obj.points.points, f"object '{obj.name}'", "point positions")
        elif ob.type == "CURVES" and shown[key]:
            obj.curves = gather_curves(ob.data, ob.data.name, f"object '{obj.name}'", warn)
            obj.materials = _curve_material(ob, obj, material_keys, warn)
        elif ob.type in UNSUPPORTED and ob.type != "CURVES":
            warn(unsupported_warning(obj.name, UNSUPPORTED[ob.type]))
        _gather_points(ob, obj, instances, world, warn)
        if instances.curves.get(key) and shown[key]:    # curves geometry nodes made
            obj.curves += instances.curves[key]
            if not obj.materials:
                obj.materials = _curve_material(ob, obj, material_keys, warn)
        obj.instances = instances.instances_of(key, world)
        rec.objects.append(obj)

    for key in sorted(material_keys):
        rec.materials[key] = gather_material(material_keys[key], warn, texture_dir)
    if scene.camera is not None and scene.camera.name_full in evaluated:
        rec.settings.camera = scene.camera.name_full
    if scene.world is not None:
        rec.world = gather_world(scene.world, warn, texture_dir)
    return groups


def _curve_material(ob, obj, material_keys, warn) -> list:
    """[the material key] of a Curves object's first slot (a USD prim of curves binds
    one material, as Blender's exporter binds it), or []; more slots in use warn."""
    slots = [s.material.original if s.material is not None else None for s in ob.material_slots]
    index = ob.data.attributes.get("material_index")
    if index is not None and len(index.data) and \
            any(d.value != 0 for d in index.data) and len(slots) > 1:
        warn(f"object '{obj.name}': its curves use {len(slots)} material slots; the first "
             f"is bound to all of them")
    first = slots[0] if slots else None
    if first is None:
        return []
    material_keys.setdefault(first.name_full, first)
    return [first.name_full]


def _gather_points(ob, obj, instances, world, warn):
    """Particles shown as halos and point clouds a modifier makes, as one Points prim."""
    found = [p for p in (obj.points, instances.points.get(obj.key),
                         particle_points(ob, np.linalg.pinv(world), warn)) if p is not None]
    if len(found) > 1:
        found[0].points = np.concatenate([p.points for p in found])
        found[0].widths = np.concatenate([p.widths for p in found])
    obj.points = found[0] if found else None
    if obj.points is not None:
        require_finite(obj.points.points, f"object '{obj.name}'", "particle positions")


def gather_geometry(ob, obj, rec, shared, rig, groups, warn, subdivision=None,
                    cage_from_data=False, rules=True):
    """`subdivision`: the trailing Subdivision Surface whose cage is written (the mesh
    read with it switched off, or from the data when `cage_from_data`), with the
    modifier's rules unless not `rules` (a polygon mesh)."""
    orig = ob.original
    is_shared = is_shareable(orig) and orig.data.name_full in shared
    mesh_key = ("proto:" + orig.data.name_full) if is_shared else ("object:" + orig.name_full)
    skinned = rig is not None and rig.reason is None
    owner = f"object '{orig.name}'"
    if mesh_key not in rec.meshes:
        # Blend shapes apply to the mesh without its shape keys: the data itself (such
        # meshes have no other modifier), with the reference key's positions. A live
        # export reads a skinned mesh's rest shape from its data likewise.
        keyed = skinned and rig.shape_keys
        from_data = keyed or (skinned and rig.rest_from_data) or \
            (subdivision is not None and cage_from_data)
        mesh = orig.data if from_data else ob.to_mesh()
        try:
            if len(mesh.polygons) == 0:
                # Points or edges only: nothing to render. Empty meshes (a metaball
                # that only feeds its family, geometry nodes that only instance) are
                # not worth a word.
                if len(mesh.vertices) and orig.type != "META":
                    warn(faceless_warning(orig.name, len(mesh.vertices), len(mesh.edges)))
                return
            name = orig.data.name if orig.type == "MESH" else orig.name
            materials = [s.material for s in ob.material_slots]
            rec.meshes[mesh_key] = gather_mesh(mesh, mesh_key, name, owner,
                                               color_attribute_names(materials), warn)
            uv_map = tangent_uv_map(materials)
            if uv_map is not None:
                rec.meshes[mesh_key].tangents = mikktspace_tangents(mesh, uv_map)
            if keyed:
                reference = mesh.shape_keys.reference_key.data
                co = np.empty(len(reference) * 3, dtype=np.float32)
                reference.foreach_get("co", co)
                require_finite(co, owner, "shape key positions")
                rec.meshes[mesh_key].points = co.reshape(-1, 3)
            if skinned and rig.armature is not None:
                groups[orig.name_full] = group_entries(mesh)
            if subdivision is not None and rules:
                rec.meshes[mesh_key].subdivision = subdivision_record(subdivision, mesh)
        finally:
            if not from_data:
                ob.to_mesh_clear()
    obj.kind, obj.mesh, obj.shared = "mesh", mesh_key, is_shared
    obj.materials = [(s.material.original.name_full, s.material.original)
                     if s.material is not None else None for s in ob.material_slots]
