"""Builds Lantern's demo scene with bpy and saves it as a .blend.

A textured ground, Suzanne with a subdivision modifier, a metal sphere, a
normal-mapped box, a rigged tentacle swaying over frames 1-24 (an armature skinning
a tube), and one light of each kind. Textures are generated here, so the demo needs
no downloaded assets.
"""
import math
import os

import bpy
import numpy as np


def _image(name, pixels, path, non_color=False):
    """Saves an RGBA float array (H, W, 4), row 0 at the bottom, as a PNG and loads it."""
    height, width = pixels.shape[:2]
    image = bpy.data.images.new(name, width, height, alpha=True)
    image.pixels.foreach_set(pixels.astype(np.float32).ravel())
    image.filepath_raw = path
    image.file_format = 'PNG'
    image.save()
    if non_color:
        image.colorspace_settings.name = 'Non-Color'
    return image


def _checker(size=256, squares=8):
    y, x = np.mgrid[0:size, 0:size] * squares // size
    value = np.where((x + y) % 2 == 0, 0.8, 0.2)
    rgba = np.ones((size, size, 4))
    rgba[..., 0] = value
    rgba[..., 1] = value * 0.9 + 0.05
    rgba[..., 2] = value * 0.7 + 0.1
    return rgba


def _bumps(size=256, cells=6):
    """A tangent-space normal map of round bumps, encoded as 0.5 + 0.5·n."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size * cells
    u, v = (x % 1.0) - 0.5, (y % 1.0) - 0.5
    r2 = np.clip(u * u + v * v, 0.0, 0.2)
    slope = 1.5 * np.where(r2 < 0.2, 1.0, 0.0)
    n = np.stack([u * slope, v * slope, np.ones_like(u)], axis=-1)  # outward on a dome
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    rgba = np.ones((size, size, 4))
    rgba[..., :3] = 0.5 + 0.5 * n
    return rgba


def _principled(name, color, metallic=0.0, roughness=0.5, image=None, normal_image=None):
    material = bpy.data.materials.new(name)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    if image is not None:
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = image
        links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    if normal_image is not None:
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = normal_image
        normal_map = nodes.new("ShaderNodeNormalMap")
        links.new(tex.outputs["Color"], normal_map.inputs["Color"])
        links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    return material


def _tentacle(scene, location, bones=4, height=2.4, rings=33, segments=16):
    """A tapered tube skinned by a chain of bones, swaying: the demo's rig."""
    arm_data = bpy.data.armatures.new("TentacleRig")
    rig = bpy.data.objects.new("TentacleRig", arm_data)
    rig.location = location
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode='EDIT')
    step, parent = height / bones, None
    for b in range(bones):
        bone = arm_data.edit_bones.new(f"Segment{b}")
        bone.head, bone.tail = (0, 0, b * step), (0, 0, (b + 1) * step)
        bone.parent, bone.use_connect = parent, parent is not None
        parent = bone
    bpy.ops.object.mode_set(mode='OBJECT')

    z = np.linspace(0.0, height, rings)
    angle = np.arange(segments) * 2 * math.pi / segments
    radius = 0.28 * (1.0 - 0.75 * z / height)
    verts = np.stack([np.outer(radius, np.cos(angle)).ravel(), np.outer(radius, np.sin(angle)).ravel(),
                      np.repeat(z, segments)], axis=1)
    faces = [(r * segments + k, r * segments + (k + 1) % segments,
              (r + 1) * segments + (k + 1) % segments, (r + 1) * segments + k)
             for r in range(rings - 1) for k in range(segments)]
    mesh = bpy.data.meshes.new("Tentacle")
    mesh.from_pydata(verts.tolist(), [], faces)
    mesh.shade_smooth()
    body = bpy.data.objects.new("Tentacle", mesh)
    scene.collection.objects.link(body)
    body.parent = rig
    body.modifiers.new("Armature", 'ARMATURE').object = rig
    for b in range(bones):
        group = body.vertex_groups.new(name=f"Segment{b}")
        weight = np.clip(1.0 - np.abs(verts[:, 2] - (b + 0.5) * step) / step, 0.0, 1.0)
        for v in np.flatnonzero(weight > 0):
            group.add([int(v)], float(weight[v]), 'REPLACE')
    body.data.materials.append(_principled("Tentacle", (0.25, 0.7, 0.35), roughness=0.35))

    for frame in (1, 7, 13, 19, 24):
        phase = (frame - 1) / 23 * 2 * math.pi
        for b, pose_bone in enumerate(rig.pose.bones):
            pose_bone.rotation_mode = 'XYZ'
            pose_bone.rotation_euler = (0.35 * math.sin(phase + b), 0.25 * math.cos(phase + 0.7 * b), 0)
            pose_bone.keyframe_insert("rotation_euler", frame=frame)


def build(blend_path, rigged=True):
    """Builds the demo and saves it to `blend_path`; rigged=False leaves out the rig."""
    out_dir = os.path.dirname(os.path.abspath(blend_path))
    tex_dir = os.path.join(out_dir, "demo_textures")
    os.makedirs(tex_dir, exist_ok=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.resolution_percentage = 100
    scene.frame_start, scene.frame_end, scene.frame_current = 1, 24, 13

    checker = _image("checker", _checker(), os.path.join(tex_dir, "checker.png"))
    bumps = _image("bumps", _bumps(), os.path.join(tex_dir, "bumps.png"), non_color=True)

    bpy.ops.mesh.primitive_plane_add(size=12.0)
    ground = bpy.context.object
    ground.name = "Ground"
    ground.data.materials.append(_principled("Checker", (1, 1, 1), roughness=0.8, image=checker))

    bpy.ops.mesh.primitive_monkey_add(location=(0.0, 0.0, 1.0), rotation=(0.0, 0.0, math.radians(20)))
    suzanne = bpy.context.object
    suzanne.name = "Suzanne"
    suzanne.modifiers.new("Subdivision", 'SUBSURF').levels = 2
    bpy.ops.object.shade_smooth()
    suzanne.data.materials.append(_principled("Clay", (0.8, 0.25, 0.15), roughness=0.45))

    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(2.2, 0.6, 0.7), segments=48, ring_count=24)
    sphere = bpy.context.object
    sphere.name = "MetalSphere"
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(_principled("Gold", (1.0, 0.77, 0.34), metallic=1.0, roughness=0.3))

    bpy.ops.mesh.primitive_cube_add(size=1.2, location=(-2.2, 0.4, 0.6), rotation=(0, 0, math.radians(30)))
    box = bpy.context.object
    box.name = "BumpyBox"
    box.data.materials.append(_principled("Bumpy", (0.3, 0.5, 0.8), roughness=0.5, normal_image=bumps))

    if rigged:
        _tentacle(scene, (1.1, -2.0, 0.0))

    def light(name, kind, energy, location, rotation=(0, 0, 0), **settings):
        data = bpy.data.lights.new(name, kind)
        data.energy = energy
        for key, value in settings.items():
            setattr(data, key, value)
        obj = bpy.data.objects.new(name, data)
        obj.location, obj.rotation_euler = location, [math.radians(a) for a in rotation]
        scene.collection.objects.link(obj)

    light("Sun", 'SUN', 2.0, (0, 0, 10), (40, 0, 30), angle=math.radians(2))
    light("Key", 'POINT', 400.0, (-2.5, -3.0, 3.5), color=(1.0, 0.85, 0.7), shadow_soft_size=0.2)
    light("Spot", 'SPOT', 800.0, (3.5, -3.5, 4.0), (45, 0, 45), spot_size=math.radians(40), spot_blend=0.3)
    light("Panel", 'AREA', 150.0, (0.0, 3.0, 3.0), (-55, 0, 0), size=2.0, color=(0.7, 0.8, 1.0))

    camera_data = bpy.data.cameras.new("Camera")
    camera_data.lens = 35
    camera = bpy.data.objects.new("Camera", camera_data)
    camera.location = (0.0, -9.0, 4.0)
    camera.rotation_euler = (math.radians(70), 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera

    world = bpy.data.worlds.new("World")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.06, 0.08, 1.0)
    scene.world = world

    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(blend_path))
