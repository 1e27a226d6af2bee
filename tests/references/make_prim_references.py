"""Renders the scenes of the prims Lantern makes surfaces of, with Cycles, once.

Implicit surfaces: renders the implicit-surface scenes (tests/implicit_scenes.py) with Cycles once,
each USD file through Blender's own USD importer (bpy.ops.wm.usd_import, lights
left out: the scene's sun and world are made in Blender from the same constants; the
importer drops implicit surfaces' material bindings, so the scene's material is bound
again);
the small EXRs are committed as implicit/<scene>.exr (RGBA over a transparent film,
so alpha is coverage; half float, ZIP).

`--mesh N` renders the matching mesh scenes instead (each shape a Mesh prim of N
sides, Lantern's triangles: implicit/<scene>_mesh<N>.exr); at N = 128 (within 0.03 %
of the radius) the exact shape's reference.

`--curves` renders the curves scene (tests/curve_scenes.py) as Blender Curves objects
made in Blender's own terms (not through the importer: see that module), as
curves/curves.exr (RGBA, half float, ZIP); `--hair` a Blender hair system
(curve_scenes.build_hair) as Cycles renders Blender's hair, as curves/hair.exr (RGB).

Cycles as for references/looks/ (make_cycles_references.configure_cycles: CPU, seed
0, no denoiser, direct light only, Blackman-Harris 1.5 px), implicit_scenes.SAMPLES
spp at implicit_scenes.SIZE. Run from the repository root:
    .venv/bin/python tests/references/make_prim_references.py [--mesh N] [NAME ...]
    .venv/bin/python tests/references/make_prim_references.py --curves | --hair
"""
import math
import pathlib
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from make_cycles_references import configure_cycles, write_exr  # noqa: E402  (Blender's pxr)

import curve_scenes  # noqa: E402
import implicit_scenes  # noqa: E402

OUT = HERE / "implicit"
CURVES = HERE / "curves"


def build(usd_path):
    """The scene: the USD file imported, the sun and world made, the camera set."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=str(usd_path), import_lights=False,
                          import_all_materials=True)
    scene = bpy.context.scene
    # Blender 5.0's importer makes a mesh of each implicit surface (GeomUtil's
    # tessellation) but drops its material binding: the scene's one material is put
    # back on every mesh without one.
    material = bpy.data.materials["Material"]
    for ob in scene.objects:
        if ob.type == 'MESH' and not ob.data.materials:
            ob.data.materials.append(material)
    scene.render.resolution_x, scene.render.resolution_y = implicit_scenes.SIZE
    scene.render.resolution_percentage = 100
    scene.camera = next(ob for ob in scene.objects if ob.type == 'CAMERA')
    # The importer scales USD's lens units; the scene's camera is set as written.
    scene.camera.data.sensor_fit = 'HORIZONTAL'
    scene.camera.data.sensor_width = 36.0
    scene.camera.data.lens = implicit_scenes.CAMERA[2]
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy, sun.data.angle = implicit_scenes.SUN, 0.0
    sun.rotation_euler = tuple(math.radians(a) for a in implicit_scenes.SUN_ROTATION)
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("World")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*implicit_scenes.WORLD, 1.0)
    scene.world = world
    return scene


def render(name, mesh_sides=None):
    suffix = "" if mesh_sides is None else f"_mesh{mesh_sides}"
    with tempfile.TemporaryDirectory() as tmp:
        usd = implicit_scenes.write_stage(name, pathlib.Path(tmp) / f"{name}.usda",
                                          as_mesh=mesh_sides is not None, segments=mesh_sides)
        scene = build(usd)
        configure_cycles(scene, implicit_scenes.SAMPLES, point_filter=False)
        scene.render.film_transparent = True        # alpha: the silhouettes
        OUT.mkdir(exist_ok=True)
        start = time.perf_counter()
        write_exr(scene, OUT / f"{name}{suffix}.exr", half=True)
    print(f"{name}{suffix}: {time.perf_counter() - start:.1f} s", flush=True)


def render_curves():
    scene = curve_scenes.build_blender()
    configure_cycles(scene, curve_scenes.SAMPLES, point_filter=False)
    scene.render.film_transparent = True
    CURVES.mkdir(exist_ok=True)
    start = time.perf_counter()
    write_exr(scene, CURVES / "curves.exr", half=True)
    print(f"curves: {time.perf_counter() - start:.1f} s", flush=True)


def render_hair():
    scene = curve_scenes.build_hair()
    configure_cycles(scene, curve_scenes.SAMPLES, point_filter=False)
    CURVES.mkdir(exist_ok=True)
    start = time.perf_counter()
    write_exr(scene, CURVES / "hair.exr", half=True, rgb=True)
    print(f"hair: {time.perf_counter() - start:.1f} s", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    if args[:1] == ["--curves"]:
        render_curves()
        raise SystemExit(0)
    if args[:1] == ["--hair"]:
        render_hair()
        raise SystemExit(0)
    sides = None
    if args[:1] == ["--mesh"]:
        sides, args = int(args[1]), args[2:]
    for scene_name in args or implicit_scenes.SCENES:
        render(scene_name, sides)
