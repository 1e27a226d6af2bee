"""The scenes of the shading work's image acceptances (tests/test_looks.py), one builder
each, shared by the Cycles reference script (references/make_cycles_references.py) and
by the tests that compare Lantern against those references. Nothing here is copied
elsewhere.

`build(name, workdir)` makes the scene current in this Blender session (factory-empty
first, or the corpus .blend opened in place) and returns it with its camera, size and
world set; generated textures are written into `workdir`. SCENES records each scene's
size and Cycles samples; the Cycles settings themselves are in the reference script.

Conventions the references share (see docs/rendering.md):
- lighting is direct only (Cycles max bounces 0): lights and the world light each
  surface once, the world through the first bounce (environment, AO, furnace);
- the materials are Principled BSDFs as Blender makes them, with Specular IOR Level 0
  where a test wants plain Lambert (albedo then equals the pixel value under a sun of
  strength pi straight down);
- the corpus scenes are read from ../shared/corpus/blender in place and changed in
  memory only, where the corpus is incomplete: their world's field.hdr is not in the
  corpus (Cycles would light them magenta), so that Environment Texture shows the
  generated asymmetric sky instead; and their materials' "glTF Metallic Roughness"
  group, linked from a glTF2.blend that is not there either (Cycles renders it
  black), becomes the Principled BSDF network Blender's glTF importer makes.
"""
import math
import os
import pathlib
from dataclasses import dataclass

import numpy as np

CORPUS = pathlib.Path(__file__).resolve().parent.parent.parent / "shared" / "corpus" / "blender"
REPO = pathlib.Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Spec:
    size: tuple          # (width, height) in pixels
    samples: int         # Cycles samples per pixel
    what: str            # what the scene checks


SCENES = {
    "environment_diffuse": Spec((128, 72), 2048, "a white Lambert sphere under an asymmetric lat-long sky"),
    "environment_mirror": Spec((128, 72), 1024, "a mirror sphere under the same sky"),
    "dome_probe": Spec((360, 64), 512, "five spheres under the same sky: white metal of roughness "
                       "1, 0.6, 0.3, a rough dielectric, a white Lambert"),
    "ao_corner": Spec((128, 72), 2048, "a box in a corner under a uniform white world"),
    "ao_node": Spec((128, 72), 2048, "ao_corner, its base colour through an Ambient Occlusion node"),
    "furnace_rough0": Spec((48, 48), 1024, "white dielectric sphere, roughness 0, uniform white world"),
    "furnace_rough05": Spec((48, 48), 1024, "white dielectric sphere, roughness 0.5, uniform white world"),
    "furnace_rough1": Spec((48, 48), 1024, "white dielectric sphere, roughness 1, uniform white world"),
    "furnace_clearcoat": Spec((48, 48), 1024, "grey sphere with coat 1 (roughness 0.1), uniform white world"),
    "transparency_planes": Spec((128, 72), 1024, "three overlapping blended planes (alpha 0.5) at three depths"),
    "cutout_shadow": Spec((128, 72), 1024, "an alpha-clipped cut-out casting a sun shadow on a floor"),
    "tex_grazing_checker": Spec((128, 72), 2048, "an 8-bit sRGB 0/1 checker seen at a grazing angle"),
    "tex_grazing_rotated": Spec((128, 128), 1024, "an 8-bit sRGB 0/1 checker on a plane turned 30 degrees, "
                                "seen through a long lens from 1.8 to 22 degrees above it"),
    "tex_gradient16": Spec((512, 8), 256, "a 16-bit PNG ramp 0..1 (Non-Color), top down"),
    "tex_exr4": Spec((16, 16), 16, "an EXR emission texture of value 4.0"),
    "02_suzanne": Spec((128, 72), 1024, "corpus: textured, normal-mapped Suzanne under the world"),
    "01_principled_material": Spec((128, 72), 1024, "corpus: textured cubes, point light"),
    "09_tex_wrapping_mirror": Spec((128, 72), 1024, "corpus: packed texture, mirror wrapping"),
    "01_alpha_blend": Spec((128, 72), 1024, "corpus: blended plane in front of a cube"),
    "01_alpha_mask": Spec((128, 72), 1024, "corpus: alpha-masked plane"),
    "demo": Spec((128, 72), 1024, "Lantern's demo scene, frame 13"),
    "sheen": Spec((280, 48), 256, "sheen: Principled (layered, over a coat), Sheen BSDFs added, alone, textured"),
}

# The sky: lat-long in Blender's equirectangular convention (row 0 = up, +Z; the
# image centre column looks along +X; u grows from +Y towards -Y, i.e. clockwise seen
# from above). Its features sit at known world directions, so a wrong orientation shows.
SKY_SIZE = (128, 64)
SKY_SUN = dict(azimuth=60.0, elevation=35.0, radius=12.0, radiance=(9.0, 7.0, 4.5))
SKY_PATCH = dict(azimuth=-120.0, elevation=10.0, radius=20.0, radiance=(0.15, 1.6, 0.25))


def direction(azimuth_deg, elevation_deg):
    """World direction (Blender, Z up): azimuth from +X towards +Y, elevation above XY."""
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def latlong_directions(height, width):
    """World directions of texel centres of a lat-long image, row 0 at the top, as
    Blender's Environment Texture maps them (Cycles' direction_to_equirectangular:
    u = 0.5 - atan2(y, x) / 2pi, v = 1 - acos(z) / pi with v = 1 the top row)."""
    u = (np.arange(width) + 0.5) / width
    t = (np.arange(height) + 0.5) / height            # 0 at the top row
    phi = (0.5 - u) * 2.0 * math.pi                   # atan2(y, x)
    theta = t * math.pi                               # acos(z)
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)


def sky_pixels(height=SKY_SIZE[1], width=SKY_SIZE[0]):
    """(H, W, 4) float32 scene-linear sky: zenith blue to a pale horizon, a brown
    ground, a warm sun blob and a green patch at known, asymmetric directions."""
    d = latlong_directions(height, width)
    z = d[..., 2:3]
    zenith, horizon, ground = np.array([0.15, 0.3, 0.9]), np.array([0.85, 0.85, 0.9]), np.array([0.3, 0.2, 0.1])
    sky = np.where(z >= 0, horizon + (zenith - horizon) * np.sqrt(np.clip(z, 0, 1)), ground)
    for blob in (SKY_SUN, SKY_PATCH):
        centre = direction(blob["azimuth"], blob["elevation"])
        angle = np.degrees(np.arccos(np.clip(d @ centre, -1, 1)))
        weight = np.exp(-0.5 * (angle / (blob["radius"] / 2.0)) ** 2)[..., None]
        sky = sky * (1 - weight) + np.array(blob["radiance"]) * weight
    rgba = np.ones((height, width, 4), np.float32)
    rgba[..., :3] = sky
    return rgba


def write_sky(workdir):
    path = os.path.join(workdir, "sky.exr")
    if not os.path.exists(path):
        _write_image(path, sky_pixels())
    return path


# --- Blender helpers -----------------------------------------------------------------------

def _empty_scene(name):
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    _size(scene, name)
    return scene


def _size(scene, name):
    scene.render.resolution_x, scene.render.resolution_y = SCENES[name].size
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0


def _camera(scene, location, target, lens=50.0, ortho_scale=None):
    import bpy
    from mathutils import Vector
    data = bpy.data.cameras.new("Camera")
    if ortho_scale is not None:
        data.type, data.ortho_scale = 'ORTHO', ortho_scale
    data.lens = lens
    data.clip_start, data.clip_end = 0.05, 200.0
    cam = bpy.data.objects.new("Camera", data)
    cam.location = location
    cam.rotation_euler = (Vector(target) - Vector(location)).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def _world(scene, color=(1.0, 1.0, 1.0), strength=1.0, image=None):
    import bpy
    world = bpy.data.worlds.new("World")
    nodes = world.node_tree.nodes
    background = nodes["Background"]
    background.inputs["Color"].default_value = (*color, 1.0)
    background.inputs["Strength"].default_value = strength
    if image is not None:
        env = nodes.new("ShaderNodeTexEnvironment")
        env.image = bpy.data.images.load(image)
        world.node_tree.links.new(env.outputs["Color"], background.inputs["Color"])
    scene.world = world
    return world


def _material(name, color=(0.8, 0.8, 0.8), roughness=0.5, metallic=0.0, specular=0.5,
              alpha=1.0, **inputs):
    import bpy
    mat = bpy.data.materials.new(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Specular IOR Level"].default_value = specular
    bsdf.inputs["Alpha"].default_value = alpha
    for key, value in inputs.items():
        bsdf.inputs[key].default_value = value
    if alpha < 1.0:
        mat.surface_render_method = 'BLENDED'
    return mat


def _lambert(name, color=(0.8, 0.8, 0.8)):
    return _material(name, color, roughness=1.0, specular=0.0)


def _mesh_object(scene, name, verts, faces, material, uvs=None):
    import bpy
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    if uvs is not None:
        layer = mesh.uv_layers.new(name="UVMap")
        layer.data.foreach_set("uv", np.asarray(uvs, np.float32).ravel())
    mesh.update()
    mesh.materials.append(material)
    ob = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(ob)
    return ob


def _quad(scene, name, corners, material, uv_scale=1.0):
    uvs = [(0, 0), (uv_scale, 0), (uv_scale, uv_scale), (0, uv_scale)]
    return _mesh_object(scene, name, corners, [(0, 1, 2, 3)], material, uvs)


def _sphere(scene, name, location, radius, material):
    import bpy
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=location, segments=64,
                                         ring_count=32)
    ob = bpy.context.object
    ob.name = name
    bpy.ops.object.shade_smooth()
    ob.data.materials.append(material)
    return ob


def _sun(scene, strength, rotation=(0.0, 0.0, 0.0), angle=0.0):
    import bpy
    data = bpy.data.lights.new("Sun", 'SUN')
    data.energy, data.angle = strength, angle
    ob = bpy.data.objects.new("Sun", data)
    ob.rotation_euler = rotation
    scene.collection.objects.link(ob)
    return ob


def _image_node(mat, path, non_color=False, link_to="Base Color", extension='REPEAT'):
    import bpy
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(path)
    tex.extension = extension
    if non_color:
        tex.image.colorspace_settings.name = "Non-Color"
    if link_to:
        links.new(tex.outputs["Color"], nodes["Principled BSDF"].inputs[link_to])
    return tex


def _write_image(path, pixels):
    """8/16-bit PNG or float EXR with OpenImageIO (Blender's, in a bpy process): no
    dependency on Lantern, so the script can measure any version of it."""
    import OpenImageIO as oiio
    kind = {np.dtype(np.uint8): "uint8", np.dtype(np.uint16): "uint16"}.get(pixels.dtype, "float")
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], kind)
    spec.attribute("oiio:UnassociatedAlpha", 1)
    tmp = path + ".tmp" + os.path.splitext(path)[1]
    out = oiio.ImageOutput.create(tmp)
    assert out.open(tmp, spec) and out.write_image(np.ascontiguousarray(pixels)), out.geterror()
    out.close()
    os.replace(tmp, path)
    return path


_write_png = _write_image


# --- builders ------------------------------------------------------------------------------

def _environment(name, material):
    """One sphere, so that no sphere sees another in a direct-light render."""
    scene = _empty_scene(name)
    _world(scene, image=write_sky(workdir=_environment.workdir))
    _sphere(scene, "Sphere", (0.0, 0.0, 0.0), 1.0, _material(*material[:2], **material[2]))
    _camera(scene, (0.0, -6.0, 1.0), (0.0, 0.0, 0.0), lens=50.0)
    return scene


def build_environment_diffuse(workdir):
    _environment.workdir = workdir
    return _environment("environment_diffuse",
                        ("White", (0.8, 0.8, 0.8), dict(roughness=1.0, specular=0.0)))


def build_environment_mirror(workdir):
    _environment.workdir = workdir
    return _environment("environment_mirror",
                        ("Mirror", (1.0, 1.0, 1.0), dict(roughness=0.0, metallic=1.0)))


# The probe's spheres, left to right: (name, colour, Principled inputs).
PROBE = (("Metal1", (1.0, 1.0, 1.0), dict(roughness=1.0, metallic=1.0)),
         ("Metal06", (1.0, 1.0, 1.0), dict(roughness=0.6, metallic=1.0)),
         ("Metal03", (1.0, 1.0, 1.0), dict(roughness=0.3, metallic=1.0)),
         ("Dielectric", (0.8, 0.8, 0.8), dict(roughness=0.5)),
         ("Lambert", (0.8, 0.8, 0.8), dict(roughness=1.0, specular=0.0)))
PROBE_SPACING = 5.0


def build_dome_probe(workdir):
    """Five unit spheres in a row along X under the sky, seen from 10 degrees above
    the horizon, each showing the dome's light alone (the dome's integral, not what
    the neighbours hide of it): in Cycles hidden from every ray but the camera's, in
    Lantern beyond the AO distance (2) of each other."""
    scene = _empty_scene("dome_probe")
    _world(scene, image=write_sky(workdir)).light_settings.distance = 2.0
    for i, (name, colour, inputs) in enumerate(PROBE):
        ob = _sphere(scene, name, ((i - 2) * PROBE_SPACING, 0.0, 0.0), 1.0,
                     _material(name, colour, **inputs))
        ob.visible_diffuse = ob.visible_glossy = ob.visible_transmission = False
        ob.visible_shadow = ob.visible_volume_scatter = False
    _camera(scene, (0.0, -60.0, 60.0 * math.tan(math.radians(10.0))), (0.0, 0.0, 0.0), lens=95.0)
    return scene


def build_ao_corner(workdir):
    scene = _empty_scene("ao_corner")
    _world(scene, (1.0, 1.0, 1.0), 1.0)
    white = _lambert("White", (0.8, 0.8, 0.8))
    _quad(scene, "Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], white)
    _quad(scene, "WallBack", [(-2, 2, 0), (2, 2, 0), (2, 2, 3), (-2, 2, 3)], white)
    _quad(scene, "WallLeft", [(-2, -2, 0), (-2, 2, 0), (-2, 2, 3), (-2, -2, 3)], white)
    import bpy
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-1.2, 1.2, 0.5))
    bpy.context.object.data.materials.append(white)
    _camera(scene, (3.2, -4.2, 2.6), (-0.8, 0.8, 0.6), lens=35.0)
    return scene


def build_ao_node(workdir):
    """ao_corner whose surfaces take their base colour (0.8 grey) through an Ambient
    Occlusion node's Color, its Distance the world's AO distance: Cycles darkens the
    albedo by its own occlusion there, Lantern by its AO pass (which uses that distance)."""
    import bpy
    scene = build_ao_corner(workdir)
    tree = bpy.data.materials["White"].node_tree
    ao = tree.nodes.new("ShaderNodeAmbientOcclusion")
    ao.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    ao.inputs["Distance"].default_value = scene.world.light_settings.distance
    tree.links.new(ao.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    return scene


# The sheen scene's spheres, left to right: (label, Principled inputs or None for none,
# Sheen BSDF (distribution, colour, roughness) or None).
SHEEN_SPHERES = (
    ("principled", dict(color=(0.05, 0.1, 0.3), roughness=0.6, **{
        "Sheen Weight": 1.0, "Sheen Roughness": 0.5}), None),
    ("principled_tint_coat", dict(color=(0.5, 0.1, 0.1), roughness=0.4, **{
        "Sheen Weight": 0.8, "Sheen Tint": (1.0, 0.8, 0.3, 1.0), "Sheen Roughness": 0.2,
        "Coat Weight": 0.5, "Coat Roughness": 0.2}), None),
    ("velvet_added", dict(color=(0.2, 0.2, 0.2), roughness=0.5),
     ("ASHIKHMIN", (0.8, 0.6, 0.4), 0.5)),
    ("microfiber_added", dict(color=(0.1, 0.3, 0.1), roughness=0.5),
     ("MICROFIBER", (0.9, 0.9, 0.9), 0.8)),
    ("microfiber_alone", None, ("MICROFIBER", (1.0, 1.0, 1.0), 0.3)),
    ("velvet_alone", None, ("ASHIKHMIN", (1.0, 1.0, 1.0), 0.2)),
    # Its colour a Checker Texture, its roughness 0.2 + 0.5 x the checker's Fac (Math).
    ("velvet_textured", dict(color=(0.2, 0.2, 0.2), roughness=0.5),
     ("ASHIKHMIN", "checker", 0.5)),
)


def build_sheen(workdir):
    """A row of spheres with sheen (SHEEN_SPHERES), lit from behind and above by a sun
    (sheen is a grazing lobe) and by a grey world."""
    import bpy
    scene = _empty_scene("sheen")
    _world(scene, (0.3, 0.3, 0.3), 1.0)
    _sun(scene, 3.0, rotation=(math.radians(-60.0), math.radians(20.0), 0.0))
    for i, (label, principled, sheen) in enumerate(SHEEN_SPHERES):
        inputs = dict(principled or {})
        mat = _material(f"Sheen_{label}", inputs.pop("color", (0.8, 0.8, 0.8)),
                        inputs.pop("roughness", 0.5), **inputs)
        tree = mat.node_tree
        output, bsdf = tree.nodes["Material Output"], tree.nodes["Principled BSDF"]
        if sheen is not None:
            node = tree.nodes.new("ShaderNodeBsdfSheen")
            node.distribution = sheen[0]
            node.inputs["Roughness"].default_value = sheen[2]
            if sheen[1] == "checker":
                checker = tree.nodes.new("ShaderNodeTexChecker")
                checker.inputs["Scale"].default_value = 3.0
                checker.inputs["Color1"].default_value = (0.9, 0.3, 0.1, 1.0)
                checker.inputs["Color2"].default_value = (0.1, 0.4, 0.9, 1.0)
                rough = tree.nodes.new("ShaderNodeMath")
                rough.operation = "MULTIPLY_ADD"
                rough.inputs[1].default_value, rough.inputs[2].default_value = 0.5, 0.2
                tree.links.new(checker.outputs["Color"], node.inputs["Color"])
                tree.links.new(checker.outputs["Fac"], rough.inputs[0])
                tree.links.new(rough.outputs[0], node.inputs["Roughness"])
            else:
                node.inputs["Color"].default_value = (*sheen[1], 1.0)
            if principled is None:
                tree.links.new(node.outputs[0], output.inputs["Surface"])
            else:
                add = tree.nodes.new("ShaderNodeAddShader")
                tree.links.new(bsdf.outputs[0], add.inputs[0])
                tree.links.new(node.outputs[0], add.inputs[1])
                tree.links.new(add.outputs[0], output.inputs["Surface"])
        _sphere(scene, f"Sphere_{label}", (1.2 * i, 0.0, 0.0), 0.5, mat)
    centre = 1.2 * (len(SHEEN_SPHERES) - 1) / 2.0
    _camera(scene, (centre, -10.0, 0.0), (centre, 0.0, 0.0),
            ortho_scale=1.2 * len(SHEEN_SPHERES))
    return scene


def _furnace(name, material, **inputs):
    scene = _empty_scene(name)
    _world(scene, (1.0, 1.0, 1.0), 1.0)
    _sphere(scene, "Sphere", (0.0, 0.0, 0.0), 1.0, _material(*material, **inputs))
    _camera(scene, (0.0, -4.0, 0.0), (0.0, 0.0, 0.0), lens=60.0)
    return scene


def build_furnace_rough0(workdir):
    return _furnace("furnace_rough0", ("White0", (1, 1, 1), 0.0))


def build_furnace_rough05(workdir):
    return _furnace("furnace_rough05", ("White05", (1, 1, 1), 0.5))


def build_furnace_rough1(workdir):
    return _furnace("furnace_rough1", ("White1", (1, 1, 1), 1.0))


def build_furnace_clearcoat(workdir):
    return _furnace("furnace_clearcoat", ("Coated", (0.5, 0.5, 0.5), 0.6),
                    **{"Coat Weight": 1.0, "Coat Roughness": 0.1})


def build_transparency_planes(workdir):
    scene = _empty_scene("transparency_planes")
    _world(scene, (1.0, 1.0, 1.0), 1.0)
    _sun(scene, 2.0, (math.radians(50), 0.0, math.radians(20)))
    _quad(scene, "Backdrop", [(-6, 3, -3), (6, 3, -3), (6, 3, 5), (-6, 3, 5)],
          _lambert("Grey", (0.5, 0.5, 0.5)))
    for i, (name, color) in enumerate([("Red", (1, 0.1, 0.1)), ("Green", (0.1, 1, 0.1)),
                                       ("Blue", (0.1, 0.1, 1))]):
        x, y = -0.6 + 0.6 * i, -1.0 + 1.0 * i
        z = 0.4 * i
        _quad(scene, name, [(x - 1, y, z - 1), (x + 1, y, z - 1), (x + 1, y, z + 1), (x - 1, y, z + 1)],
              _material(name, color, roughness=0.5, alpha=0.5))
    _camera(scene, (0.8, -7.0, 1.0), (0.0, 0.0, 0.3), lens=40.0)
    return scene


def cutout_mask(size=64, holes=4):
    """RGBA 8-bit: white, alpha 0 inside a grid of round holes (row 0 = top)."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size * holes
    inside = (x % 1 - 0.5) ** 2 + (y % 1 - 0.5) ** 2 < 0.3 ** 2
    rgba = np.full((size, size, 4), 255, np.uint8)
    rgba[..., 3] = np.where(inside, 0, 255)
    return rgba


def build_cutout_shadow(workdir):
    """A horizontal plate with round holes 1 m above a floor, a sun 40 degrees off the
    vertical: the plate and its shadow side by side. The glTF-style clip: texture
    alpha -> Math Greater Than 0.5 -> Alpha."""
    scene = _empty_scene("cutout_shadow")
    _world(scene, (0.05, 0.05, 0.05), 1.0)
    _sun(scene, 3.0, (0.0, math.radians(40), 0.0))
    _quad(scene, "Floor", [(-5, -4, 0), (5, -4, 0), (5, 4, 0), (-5, 4, 0)], _lambert("Floor"))
    mat = _lambert("Cutout", (0.9, 0.6, 0.2))
    mat.blend_method = 'CLIP'
    tex = _image_node(mat, _write_png(os.path.join(workdir, "cutout.png"), cutout_mask()))
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    greater = nodes.new("ShaderNodeMath")
    greater.operation = 'GREATER_THAN'
    greater.inputs[1].default_value = 0.5
    links.new(tex.outputs["Alpha"], greater.inputs[0])
    links.new(greater.outputs["Value"], nodes["Principled BSDF"].inputs["Alpha"])
    _quad(scene, "Cutout", [(-1.8, -1, 1), (0.2, -1, 1), (0.2, 1, 1), (-1.8, 1, 1)], mat)
    _camera(scene, (0.0, -5.5, 5.5), (0.0, 0.0, 0.3), lens=35.0)
    return scene


def checker_pixels(size=256, cells=16):
    """8-bit 0/255 checker, RGB."""
    y, x = np.mgrid[0:size, 0:size] * cells // size
    value = np.where((x + y) % 2 == 0, 255, 0).astype(np.uint8)
    return np.dstack([value] * 3)


def build_tex_grazing_checker(workdir):
    """A sun of irradiance pi straight down: a pixel reads its (linear) albedo."""
    scene = _empty_scene("tex_grazing_checker")
    _world(scene, (0.0, 0.0, 0.0), 0.0)
    _sun(scene, math.pi)
    mat = _lambert("Checker", (1.0, 1.0, 1.0))
    _image_node(mat, _write_png(os.path.join(workdir, "checker.png"), checker_pixels()))
    _quad(scene, "Ground", [(-20, -2, 0), (20, -2, 0), (20, 38, 0), (-20, 38, 0)], mat, uv_scale=10.0)
    _camera(scene, (0.0, -2.0, 0.6), (0.0, 10.0, 0.0), lens=35.0)
    return scene


def build_tex_grazing_rotated(workdir):
    """A 0/1 checker of 32 x 32 cells (8 px each) tiled 40 times on an 80 m plane turned
    30 degrees about the vertical, seen from 0.6 m above it through a 100 mm lens
    looking 12 degrees down: from the top row (1.8 degrees above the plane, 19 m
    away) to the bottom (22 degrees), the plane fills the frame (no horizon: the
    plane's far side is a geometric edge, not a texture's). A sun of irradiance pi
    straight down: a pixel reads its albedo."""
    scene = _empty_scene("tex_grazing_rotated")
    _world(scene, (0.0, 0.0, 0.0), 0.0)
    _sun(scene, math.pi)
    mat = _lambert("Checker", (1.0, 1.0, 1.0))
    _image_node(mat, _write_png(os.path.join(workdir, "checker32.png"), checker_pixels(256, 32)))
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    corners = [(x * c - y * s, 20.0 + x * s + y * c, 0.0)
               for x, y in ((-40, -40), (40, -40), (40, 40), (-40, 40))]
    _quad(scene, "Ground", corners, mat, uv_scale=40.0)
    down = math.radians(12.0)
    _camera(scene, (0.0, -2.0, 0.6), (0.0, -2.0 + 10.0 * math.cos(down), 0.6 - 10.0 * math.sin(down)),
            lens=100.0)
    return scene


def gradient16_pixels(width=1024, height=4):
    ramp = np.round(np.linspace(0, 65535, width)).astype(np.uint16)
    return np.dstack([np.broadcast_to(ramp, (height, width))] * 3)


def build_tex_gradient16(workdir):
    scene = _empty_scene("tex_gradient16")
    _world(scene, (0.0, 0.0, 0.0), 0.0)
    _sun(scene, math.pi)
    mat = _lambert("Ramp", (1.0, 1.0, 1.0))
    _image_node(mat, _write_png(os.path.join(workdir, "ramp16.png"), gradient16_pixels()),
                non_color=True, extension='EXTEND')
    _quad(scene, "Strip", [(-4, -0.0625, 0), (4, -0.0625, 0), (4, 0.0625, 0), (-4, 0.0625, 0)], mat)
    _camera(scene, (0.0, 0.0, 5.0), (0.0, 0.0, 0.0), ortho_scale=8.0)
    return scene


def build_tex_exr4(workdir):
    """Black, non-reflecting surface whose emission colour is an EXR texture of 4.0."""
    scene = _empty_scene("tex_exr4")
    _world(scene, (0.0, 0.0, 0.0), 0.0)
    path = _write_image(os.path.join(workdir, "four.exr"), np.full((8, 8, 4), 4.0, np.float32))
    mat = _material("Four", (0.0, 0.0, 0.0), roughness=1.0, specular=0.0,
                    **{"Emission Strength": 1.0})
    tex = _image_node(mat, path, non_color=False, link_to="Emission Color")
    tex.image.colorspace_settings.name = "Linear Rec.709"
    _quad(scene, "Quad", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], mat)
    _camera(scene, (0.0, 0.0, 5.0), (0.0, 0.0, 0.0), ortho_scale=3.0)
    return scene


def _principled_for_gltf_group(material):
    """Replaces the "glTF Metallic Roughness" group (linked from a glTF2.blend that is
    not in the corpus: Cycles renders it black) with the Principled BSDF network
    Blender's glTF importer makes: base colour (x factor), metallic/roughness from B/G,
    a tangent normal map, emission, alpha (blend, or a Greater Than clip for MASK)."""
    tree = material.node_tree
    nodes, links = tree.nodes, tree.links
    for group in [n for n in nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None
                  and n.node_tree.name == "glTF Metallic Roughness"]:
        get = group.inputs.get
        bsdf = nodes.new("ShaderNodeBsdfPrincipled")

        def source(name):
            return get(name).links[0].from_socket if get(name).is_linked else None

        factor = tuple(get("BaseColorFactor").default_value)
        bsdf.inputs["Base Color"].default_value = factor
        colour = source("BaseColor")
        if colour is not None:
            if factor[:3] == (1.0, 1.0, 1.0):
                links.new(colour, bsdf.inputs["Base Color"])
            else:
                mix = nodes.new("ShaderNodeMix")
                mix.data_type, mix.blend_type = 'RGBA', 'MULTIPLY'
                mix.inputs["Factor"].default_value = 1.0
                links.new(colour, mix.inputs[6])
                mix.inputs[7].default_value = factor
                links.new(mix.outputs[2], bsdf.inputs["Base Color"])
        bsdf.inputs["Metallic"].default_value = get("MetallicFactor").default_value
        bsdf.inputs["Roughness"].default_value = get("RoughnessFactor").default_value
        orm = source("MetallicRoughness")
        if orm is not None:
            split = nodes.new("ShaderNodeSeparateColor")
            links.new(orm, split.inputs[0])
            links.new(split.outputs["Green"], bsdf.inputs["Roughness"])
            links.new(split.outputs["Blue"], bsdf.inputs["Metallic"])
        normal = source("Normal")
        if normal is not None:
            nmap = nodes.new("ShaderNodeNormalMap")
            nmap.inputs["Strength"].default_value = get("NormalScale").default_value
            links.new(normal, nmap.inputs["Color"])
            links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
        emission = tuple(get("EmissiveFactor").default_value)[:3]
        if any(emission):
            bsdf.inputs["Emission Color"].default_value = (*emission, 1.0)
            bsdf.inputs["Emission Strength"].default_value = 1.0
        alpha = source("Alpha")
        if alpha is not None:
            if get("AlphaMode").default_value >= 0.5:      # MASK
                clip = nodes.new("ShaderNodeMath")
                clip.operation = 'GREATER_THAN'
                clip.inputs[1].default_value = get("AlphaCutoff").default_value
                links.new(alpha, clip.inputs[0])
                links.new(clip.outputs["Value"], bsdf.inputs["Alpha"])
                material.blend_method = 'CLIP'
            else:
                links.new(alpha, bsdf.inputs["Alpha"])
                material.surface_render_method = 'BLENDED'
        for link in list(group.outputs[0].links):
            links.new(bsdf.outputs["BSDF"], link.to_socket)
        nodes.remove(group)


def _corpus(name, workdir):
    import bpy
    bpy.ops.wm.open_mainfile(filepath=str(CORPUS / f"{name}.blend"), load_ui=False)
    scene = bpy.context.scene
    _size(scene, name)
    for material in bpy.data.materials:
        if material.node_tree is not None:
            _principled_for_gltf_group(material)
    world = scene.world
    if world is not None and world.node_tree is not None:
        for node in world.node_tree.nodes:
            if node.bl_idname == "ShaderNodeTexEnvironment" and node.image is not None \
                    and node.image.packed_file is None \
                    and not os.path.isfile(bpy.path.abspath(node.image.filepath)):
                node.image = bpy.data.images.load(write_sky(workdir))
    return scene


def build_02_suzanne(workdir):
    return _corpus("02_suzanne", workdir)


def build_01_principled_material(workdir):
    return _corpus("01_principled_material", workdir)


def build_09_tex_wrapping_mirror(workdir):
    """The file has no camera: one looking down at both textured quads."""
    scene = _corpus("09_tex_wrapping_mirror", workdir)
    import bpy
    from mathutils import Vector
    points = [ob.matrix_world @ Vector(c) for ob in scene.objects if ob.type == 'MESH'
              for c in ob.bound_box]
    lo = Vector([min(p[i] for p in points) for i in range(3)])
    hi = Vector([max(p[i] for p in points) for i in range(3)])
    centre, extent = (lo + hi) / 2, max((hi - lo).x, (hi - lo).y * 16 / 9)
    _camera(scene, centre + Vector((0.0, 0.0, 2.0 * extent)), centre, ortho_scale=1.1 * extent)
    return scene


def build_01_alpha_blend(workdir):
    return _corpus("01_alpha_blend", workdir)


def build_01_alpha_mask(workdir):
    return _corpus("01_alpha_mask", workdir)


def build_demo(workdir):
    import bpy
    from lantern.demo.build_scene import build as build_demo_blend
    build_demo_blend(os.path.join(workdir, "demo.blend"))
    scene = bpy.context.scene
    scene.frame_set(13)
    _size(scene, "demo")
    return scene


def build(name, workdir):
    """The scene `name` of SCENES, current in this Blender session."""
    os.makedirs(workdir, exist_ok=True)
    return globals()["build_" + name](str(workdir))
