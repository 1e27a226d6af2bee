"""Calibration scenes: one light over a white Lambert plane, seen straight down by an
orthographic camera, and the closed-form radiance Blender's light units give there.

Shared by the tests and by `references/make_cycles_references.py`, which renders the
same scenes with Cycles once. The forms (docs/rendering.md):
- point/spot: I = Φ/(4π) W/sr; E = I·cosθ/(d²+r²) with soft falloff (r = radius);
- spot mask: smoothstep(0, 1, (cosφ − cos(size/2)) / ((1 − cos(size/2))·blend));
- sun: E = S·cosθ;
- area: radiance Φ/(π·A), one-sided; E is its polygon form factor (exact for Lambert);
- a white Lambert surface leaves radiance E/π.
"""
import math

import numpy as np

SIZE = 48            # pixels, square
ORTHO_SCALE = 8.0    # metres across the image
CAMERA_HEIGHT = 10.0

LIGHTS = {
    "sun": dict(type='SUN', energy=3.0, location=(0, 0, 5), rotation=(math.radians(35), 0, 0)),
    "point": dict(type='POINT', energy=1000.0, location=(0.5, -0.3, 2.0), radius=0.1),
    "spot": dict(type='SPOT', energy=1000.0, location=(0.0, 0.0, 2.5), radius=0.0,
                 spot_size=math.radians(60), spot_blend=0.3),
    "area": dict(type='AREA', energy=200.0, location=(0.0, 0.0, 1.5), size=1.0),
}


def pixel_world_points():
    """World (x, y) of every pixel centre, row 0 at the top of the image (+Y)."""
    centres = (np.arange(SIZE) + 0.5) / SIZE * ORTHO_SCALE - ORTHO_SCALE / 2
    x = np.broadcast_to(centres[None, :], (SIZE, SIZE))
    y = np.broadcast_to(-centres[:, None], (SIZE, SIZE))
    return x, y


def _smoothstep(t):
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def polygon_irradiance(vertices, points):
    """Irradiance on an upward (+Z) receiver from a unit-radiance polygon (Lambert's formula).

    vertices: (N, 3) in order; points: (..., 3). The polygon lies above the receivers.
    """
    total = np.zeros(points.shape[:-1])
    for i in range(len(vertices)):
        a = vertices[i] - points
        b = vertices[(i + 1) % len(vertices)] - points
        a /= np.linalg.norm(a, axis=-1, keepdims=True)
        b /= np.linalg.norm(b, axis=-1, keepdims=True)
        cross = np.cross(a, b)
        angle = np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0))
        total += angle * cross[..., 2] / np.maximum(np.linalg.norm(cross, axis=-1), 1e-12)
    return np.abs(total) / 2.0


def closed_form_radiance(kind):
    """Radiance (W/(sr·m²)) leaving the white plane at every pixel, for LIGHTS[kind]."""
    light = LIGHTS[kind]
    x, y = pixel_world_points()
    if kind == "sun":
        cos_theta = math.cos(light["rotation"][0])
        return np.full((SIZE, SIZE), light["energy"] * cos_theta / math.pi)
    lx, ly, lz = light["location"]
    dx, dy = x - lx, y - ly
    d2 = dx * dx + dy * dy + lz * lz
    if kind in ("point", "spot"):
        intensity = light["energy"] / (4.0 * math.pi)
        irradiance = intensity * (lz / np.sqrt(d2)) / (d2 + light["radius"] ** 2)
        if kind == "spot":
            cos_phi = lz / np.sqrt(d2)  # spot axis points straight down
            cos_half = math.cos(light["spot_size"] / 2)
            irradiance = irradiance * _smoothstep(
                (cos_phi - cos_half) / ((1.0 - cos_half) * light["spot_blend"]))
        return irradiance / math.pi
    half = light["size"] / 2
    corners = np.array([[lx - half, ly - half, lz], [lx + half, ly - half, lz],
                        [lx + half, ly + half, lz], [lx - half, ly + half, lz]])
    radiance = light["energy"] / (math.pi * light["size"] ** 2)
    points = np.stack([x, y, np.zeros_like(x)], axis=-1)
    return radiance * polygon_irradiance(corners, points) / math.pi


def add_light(scene, name, spec, shadow):
    """A Blender light from a spec of LIGHTS or BOX_LIGHTS: aimed at spec["target"],
    or turned by spec["rotation"]; a sun without an "angle" is a sharp one."""
    import bpy
    from mathutils import Vector
    data = bpy.data.lights.new(name, spec["type"])
    data.energy = spec["energy"]
    data.use_shadow = shadow
    if spec["type"] in ('POINT', 'SPOT'):
        data.shadow_soft_size = spec["radius"]
    if spec["type"] == 'SPOT':
        data.spot_size, data.spot_blend = spec["spot_size"], spec["spot_blend"]
    if spec["type"] == 'SUN':
        data.angle = spec.get("angle", 0.0)
    if spec["type"] == 'AREA':
        data.shape, data.size = 'SQUARE', spec["size"]
    light = bpy.data.objects.new(name, data)
    light.location = spec["location"]
    if "target" in spec:
        light.rotation_euler = (Vector(spec["target"]) - light.location).to_track_quat('-Z', 'Y').to_euler()
    else:
        light.rotation_euler = spec.get("rotation", (0, 0, 0))
    scene.collection.objects.link(light)
    return light


def build_scene(kind):
    """The calibration scene in the current Blender session (factory-empty first)."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100

    bpy.ops.mesh.primitive_plane_add(size=40.0)
    plane = bpy.context.object
    material = bpy.data.materials.new("WhiteLambert")
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (1, 1, 1, 1)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    plane.data.materials.append(material)

    camera_data = bpy.data.cameras.new("Camera")
    camera_data.type = 'ORTHO'
    camera_data.ortho_scale = ORTHO_SCALE
    camera = bpy.data.objects.new("Camera", camera_data)
    camera.location = (0.0, 0.0, CAMERA_HEIGHT)
    scene.collection.objects.link(camera)
    scene.camera = camera

    add_light(scene, kind, LIGHTS[kind], shadow=False)

    world = bpy.data.worlds.new("Black")
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    return scene


# --- Box on a plane: shadows against Cycles ---------------------------------------

BOX_SIZE = (96, 54)
BOX_LIGHTS = {
    "sun": dict(type='SUN', energy=3.0, location=(0, 0, 5),
                rotation=(math.radians(40), 0, math.radians(30)), angle=math.radians(5)),
    "point": dict(type='POINT', energy=600.0, location=(1.5, -1.2, 2.5), radius=0.1),
    "spot": dict(type='SPOT', energy=1500.0, location=(-1.5, -1.8, 3.0), radius=0.1,
                 spot_size=math.radians(60), spot_blend=0.2, target=(0.0, 0.0, 0.0)),
    "area": dict(type='AREA', energy=300.0, location=(1.2, -1.2, 2.5), size=1.0,
                 target=(0.0, 0.0, 0.0)),
}


def build_box_scene(kind):
    """A white unit box on the white plane, one shadow-casting light, a perspective
    camera, no world light."""
    import bpy
    from mathutils import Vector
    scene = build_scene("sun")  # plane, material, black world; its light is replaced
    bpy.data.objects.remove(bpy.data.objects["sun"])
    scene.render.resolution_x, scene.render.resolution_y = BOX_SIZE
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 0.5))
    bpy.context.object.data.materials.append(bpy.data.materials["WhiteLambert"])

    camera = scene.camera
    camera.data.type = 'PERSP'
    camera.data.lens = 35
    camera.location = (4.0, -5.0, 3.5)
    camera.rotation_euler = (Vector((0.0, 0.0, 0.4)) - camera.location).to_track_quat('-Z', 'Y').to_euler()

    add_light(scene, kind, BOX_LIGHTS[kind], shadow=True)
    return scene
