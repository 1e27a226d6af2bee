"""The scene as every Blender-side worker sees it (Cycles, EEVEE, and Lantern's
export): the .blend opened, at the frame and size asked, with a camera.

Each worker opens the file itself, so every renderer starts from the same data. A
scene without a camera gets one, made the same way in every worker (Cycles and EEVEE
cannot render without one), and the report says so. `links` lists what the file
points to outside itself (libraries and image files) and which are missing: the
renders go on with what exists."""
from __future__ import annotations

import math
import os

import bpy
from mathutils import Vector

ADDED_CAMERA = "lantern_compare_camera"
# The added camera looks down this direction (a three-quarter view from the front
# right, above), through a 50 mm lens on a 36 mm sensor.
VIEW_DIRECTION = Vector((-1.0, 1.0, -0.7)).normalized()


def open_scene(path: str, frame: float | None = None, size=None) -> list:
    """Opens `path` as the current file and prepares it; returns the notes (strings)
    on what was changed for the comparison."""
    from ..exporters import open_blend  # checks the header and names the file on failure
    scene = open_blend(path)
    notes = []
    if frame is not None:
        whole = math.floor(frame)
        scene.frame_set(int(whole), subframe=float(frame - whole))
    if size is not None:
        scene.render.resolution_x, scene.render.resolution_y = size
        scene.render.resolution_percentage = 100
    if scene.camera is None:
        _add_camera(scene)
        notes.append("the scene has no camera: compare added one framing the visible "
                     "objects (a three-quarter view, 50 mm), the same for every renderer")
    return notes


def _world_bounds(scene):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    corners = []
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type not in {"MESH", "CURVE", "SURFACE", "META", "FONT", "POINTCLOUD"}:
            continue
        matrix = instance.matrix_world
        corners.extend(matrix @ Vector(c) for c in obj.bound_box)
    if not corners:
        return Vector((0, 0, 0)), 1.0
    low = Vector(tuple(min(c[i] for c in corners) for i in range(3)))
    high = Vector(tuple(max(c[i] for c in corners) for i in range(3)))
    return (low + high) / 2, max((high - low).length / 2, 1e-3)


def _add_camera(scene):
    center, radius = _world_bounds(scene)
    data = bpy.data.cameras.new(ADDED_CAMERA)
    data.lens, data.sensor_width, data.sensor_fit = 50.0, 36.0, "AUTO"
    camera = bpy.data.objects.new(ADDED_CAMERA, data)
    scene.collection.objects.link(camera)
    aspect = scene.render.resolution_x / max(1, scene.render.resolution_y)
    # AUTO sensor fit: the sensor's 36 mm span the image's longer side.
    narrow = math.atan(18.0 / data.lens / max(aspect, 1.0 / aspect))
    distance = radius / math.sin(narrow) * 1.05
    camera.location = center - VIEW_DIRECTION * distance
    camera.rotation_euler = VIEW_DIRECTION.to_track_quat("-Z", "Y").to_euler()
    data.clip_start, data.clip_end = max(distance - radius * 2, 1e-3) * 0.1, (distance + radius) * 2
    scene.camera = camera
    bpy.context.view_layer.update()


def _file_state(path, library=None):
    resolved = os.path.normpath(bpy.path.abspath(path, library=library))
    return resolved, os.path.isfile(resolved)


def links() -> list:
    """Every library and image file the open .blend points to: kind, name, the path as
    written, the resolved path, and whether it exists (packed images count as present)."""
    found = []
    for library in bpy.data.libraries:
        resolved, exists = _file_state(library.filepath)
        found.append({"kind": "library", "name": library.name, "path": library.filepath,
                      "resolved": resolved, "exists": exists})
    for image in bpy.data.images:
        if image.source not in {"FILE", "SEQUENCE", "MOVIE", "TILED"} or not image.filepath:
            continue
        resolved, exists = _file_state(image.filepath, image.library)
        packed = image.packed_file is not None
        found.append({"kind": "image", "name": image.name, "path": image.filepath,
                      "resolved": resolved, "exists": exists or packed, "packed": packed})
    return found


def describe(scene) -> dict:
    from ..exporters.gather.scene import colour_management
    render = scene.render
    scale = render.resolution_percentage / 100.0
    transform, look, exposure = colour_management(scene)
    return {"name": scene.name, "frame": scene.frame_current + scene.frame_subframe,
            "resolution": [max(1, round(render.resolution_x * scale)),
                           max(1, round(render.resolution_y * scale))],
            "film_transparent": bool(render.film_transparent),
            "camera": scene.camera.name if scene.camera else None,
            "view": {"transform": transform, "look": look, "exposure": exposure},
            "blender": bpy.app.version_string}
