"""Area-light highlights (docs/rendering.md, "Area lights"): a glossy floor reflecting an
area light, as a user sees it with `lantern compare`. Shared by the Cycles reference
script (references/make_cycles_references.py highlight: 1024 spp, bounces 0, Cycles'
default pixel filter) and tests/test_area_highlights.py.

- rect: a dark glossy floor (base 0.05, roughness 0.15) under a 2 x 0.4 m rectangular
  light, a low camera, a gold sphere (metallic, roughness 0.25) lit from behind;
- disk: the same with a 0.9 m disk light;
- rect_rough: the rect scene with a floor of roughness 0.4;
- rect_unshadowed: the rect scene, its light casting no shadow (the highlight alone:
  the sphere's shadow falls across it in the others);
- sphere: a point light of radius 0.3 m (a sphere light; Blender's soft falloff, its
  default) 1.5 m to the side, so that the sphere's shadow misses its reflection, over a
  floor of roughness 0.05, where its highlight is a disk.
A black world: only the light lights them."""
import reference_scenes as rs

SIZE = (160, 120)
SAMPLES = 1024
FLOOR = dict(color=(0.05, 0.05, 0.05), roughness=0.15)
GOLD = dict(color=(1.0, 0.766, 0.336), roughness=0.25, metallic=1.0)
LIGHTS = {
    "rect": dict(shape='RECTANGLE', size=2.0, size_y=0.4, energy=200.0),
    "disk": dict(shape='DISK', size=0.9, energy=200.0),
    "sphere": dict(type='POINT', radius=0.3, energy=300.0, at=(1.5, 3.0, 1.5)),
}
# name: (light, floor roughness, shadow)
SCENES = {"rect": ("rect", 0.15, True), "disk": ("disk", 0.15, True),
          "rect_rough": ("rect", 0.4, True), "rect_unshadowed": ("rect", 0.15, False),
          "sphere": ("sphere", 0.05, True)}
LIGHT_AT = (0.0, 3.0, 1.5)          # facing straight down, behind the sphere
CAMERA = ((0.0, -5.0, 0.6), (0.0, 0.0, 0.3))


def build(name, workdir=None):
    """The scene `name` of SCENES, current in this Blender session."""
    import bpy
    light_kind, roughness, shadow = SCENES[name]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    floor = rs._material("Floor", FLOOR["color"], roughness=roughness)
    rs._quad(scene, "Floor", [(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], floor)
    rs._sphere(scene, "Gold", (0.0, 0.0, 0.5), 0.5,
               rs._material("Gold", GOLD["color"], roughness=GOLD["roughness"],
                            metallic=GOLD["metallic"]))
    rs._camera(scene, *CAMERA)
    rs._world(scene, strength=0.0)
    spec = LIGHTS[light_kind]
    data = bpy.data.lights.new("Area", spec.get("type", 'AREA'))
    data.energy = spec["energy"]
    if data.type == 'AREA':
        data.shape, data.size = spec["shape"], spec["size"]
    else:
        data.shadow_soft_size = spec["radius"]
    if "size_y" in spec:
        data.size_y = spec["size_y"]
    data.use_shadow = shadow
    light = bpy.data.objects.new("Area", data)
    light.location = spec.get("at", LIGHT_AT)
    scene.collection.objects.link(light)
    return scene
