"""Clearcoat in a white furnace: one sphere under a uniform white world, its base a
grey dielectric (roughness 0.5) under a coat of IOR 1.5, at every coat weight and
roughness of CASES, over a dark and a bright base.

Shared by tests/test_clearcoat.py and by `references/make_cycles_references.py
clearcoat`, which renders them with Cycles once into references/clearcoat/<name>.exr
(direct light only, SAMPLES spp: a furnace needs no more, and 18 of them render in a
few minutes on 2 cores)."""
import itertools

SIZE = (48, 48)
SAMPLES = 1024
BASES = {"dark": 0.1, "bright": 0.8}     # base colour (grey), roughness BASE_ROUGHNESS
BASE_ROUGHNESS = 0.5
WEIGHTS = (0.25, 0.5, 1.0)
ROUGHNESS = (0.03, 0.1, 0.5)
CASES = {f"coat_{base}_w{weight:g}_r{rough:g}": (BASES[base], weight, rough)
         for base, weight, rough in itertools.product(BASES, WEIGHTS, ROUGHNESS)}


def build(name):
    """The scene `name` of CASES, current in this Blender session (factory-empty first)."""
    import bpy
    import reference_scenes as rs
    grey, weight, rough = CASES[name]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    rs._world(scene, (1.0, 1.0, 1.0), 1.0)
    material = rs._material(name, (grey, grey, grey), BASE_ROUGHNESS, **{
        "Coat Weight": weight, "Coat Roughness": rough, "Coat IOR": 1.5})
    rs._sphere(scene, "Sphere", (0.0, 0.0, 0.0), 1.0, material)
    rs._camera(scene, (0.0, -4.0, 0.0), (0.0, 0.0, 0.0), lens=60.0)
    return scene
