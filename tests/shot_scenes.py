"""Shots that need light Lantern does not draw yet: the bounce, emitters as lights, area-light
highlights and glass. One builder each, shared by the Cycles reference script
(references/make_shot_references.py), the bench (bench/bench_shots.py) and the tests
(tests/test_shots.py); built in Blender, so that `lantern export` and Cycles see one scene.

- cornell_box: a closed box (camera inside), red left and green right wall, white
  elsewhere, two white blocks, a square area light under the ceiling;
- sunlit_room: a closed room of zero-thickness walls meeting at seams, lit only by a
  sharp sun through a window in one wall (black world);
- emissive_table: a table with a sphere in a room corner, lit only by an emissive
  panel (an Emission shader on a 1.2 x 0.6 m quad, strength 8) above it: no lamp,
  black world;
- glass_sphere: a clear glass sphere (Principled, Transmission 1, IOR 1.45, roughness 0)
  on a checker floor under a sun and a blue world;
- glossy_floor: a dark glossy floor (roughness 0.15) under a 2 x 0.4 m rectangular area
  light, seen from a low camera, with a gold sphere; black world.

SHOTS records, per shot, the modes its Cycles references are rendered in (compare's
modes: `full` keeps Cycles' default bounces, max 12, diffuse 4, glossy 4; `direct` sets
max bounces 0) and what it shows.
"""
import math
import pathlib
from dataclasses import dataclass

import reference_scenes as rs

SIZE = (160, 120)
REFERENCES = pathlib.Path(__file__).resolve().parent / "references" / "shots"


@dataclass(frozen=True)
class Shot:
    modes: tuple         # compare modes the references are rendered in
    what: str


SHOTS = {
    "cornell_box": Shot(("full", "direct"), "closed box, red and green walls, two blocks, "
                        "ceiling area light"),
    "sunlit_room": Shot(("full",), "closed room lit only by a sun through a window"),
    "emissive_table": Shot(("full", "direct"), "table and sphere lit only by an emissive "
                           "panel (1.2 x 0.6 m, strength 8)"),
    "glass_sphere": Shot(("full", "direct"), "glass sphere (Transmission 1, IOR 1.45) on a "
                         "checker, sun and blue world"),
    "glossy_floor": Shot(("direct",), "dark glossy floor (roughness 0.15) under a 2 x 0.4 m "
                         "area light, low camera, gold sphere"),
}


def reference_path(name, mode):
    return REFERENCES / f"{name}_{mode}.exr"


def cases():
    """Every (shot, mode) with a reference."""
    return [(name, mode) for name, shot in SHOTS.items() for mode in shot.modes]


# --- helpers -------------------------------------------------------------------------------

def _scene():
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    return scene


def _box(scene, name, centre, size, material, turn_deg=0.0):
    """An axis-aligned box of `size` turned about Z by `turn_deg`, its base at centre.z."""
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    hx, hy, h = size[0] / 2, size[1] / 2, size[2]
    verts = []
    for z in (0.0, h):
        for x, y in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)):
            verts.append((centre[0] + c * x - s * y, centre[1] + s * x + c * y, centre[2] + z))
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return rs._mesh_object(scene, name, verts, faces, material)


def _aimed(ob, direction):
    """Turns a light (which shines along its -Z) to shine along `direction`."""
    from mathutils import Vector
    ob.rotation_euler = Vector(direction).to_track_quat('-Z', 'Y').to_euler()
    return ob


def _area(scene, name, size, energy, location, direction=(0, 0, -1)):
    import bpy
    data = bpy.data.lights.new(name, 'AREA')
    data.shape = 'RECTANGLE' if size[0] != size[1] else 'SQUARE'
    data.size, data.size_y = size
    data.energy = energy
    ob = bpy.data.objects.new(name, data)
    ob.location = location
    scene.collection.objects.link(ob)
    return _aimed(ob, direction)


def _emission(name, strength, color=(1.0, 1.0, 1.0)):
    import bpy
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new("ShaderNodeEmission")
    node.inputs["Color"].default_value = (*color, 1.0)
    node.inputs["Strength"].default_value = strength
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def room_walls(low, high) -> dict:
    """The corners of six inward quads of zero thickness that close the box from `low`
    to `high`, meeting at seams: Floor, Ceiling, WallXn, WallXp, WallYn, WallYp."""
    (x0, y0, z0), (x1, y1, z1) = low, high
    return {
        "Floor": [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],
        "Ceiling": [(x0, y0, z1), (x0, y1, z1), (x1, y1, z1), (x1, y0, z1)],
        "WallXn": [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)],
        "WallXp": [(x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)],
        "WallYn": [(x0, y0, z0), (x0, y0, z1), (x1, y0, z1), (x1, y0, z0)],
        "WallYp": [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
    }


def _room(scene, low, high, materials, skip=()):
    """room_walls as meshes; `materials` maps a name to its material (default "White")."""
    for name, corners in room_walls(low, high).items():
        if name not in skip:
            rs._quad(scene, name, corners, materials.get(name, materials["White"]))


# --- builders ------------------------------------------------------------------------------

def build_cornell_box():
    scene = _scene()
    rs._world(scene, (0.0, 0.0, 0.0), 0.0)
    white = rs._lambert("White", (0.73, 0.73, 0.73))
    _room(scene, (-1, -1, 0), (1, 1, 2), {"White": white,
                                           "WallXn": rs._lambert("Red", (0.63, 0.065, 0.05)),
                                           "WallXp": rs._lambert("Green", (0.14, 0.45, 0.091))})
    _box(scene, "TallBlock", (-0.35, 0.3, 0.0), (0.55, 0.55, 1.2), white, turn_deg=18.0)
    _box(scene, "ShortBlock", (0.38, -0.25, 0.0), (0.55, 0.55, 0.6), white, turn_deg=-16.0)
    _area(scene, "CeilingLight", (0.5, 0.5), 20.0, (0.0, 0.0, 1.98))
    rs._camera(scene, (0.0, -0.97, 1.0), (0.0, 1.0, 0.95), lens=20.0)
    return scene


def build_sunlit_room():
    scene = _scene()
    rs._world(scene, (0.0, 0.0, 0.0), 0.0)
    white = rs._lambert("White", (0.8, 0.8, 0.8))
    _room(scene, (-2, -2, 0), (2, 2, 2.6),
          {"White": white, "Floor": rs._lambert("Floor", (0.6, 0.45, 0.3))}, skip=("WallXp",))
    # The window wall (x = 2) as four quads around a 1.2 x 1 m opening.
    (w0, w1), (h0, h1) = (-0.6, 0.6), (0.8, 1.8)
    for name, (ya, yb, za, zb) in {"WallBelow": (-2, 2, 0, h0), "WallAbove": (-2, 2, h1, 2.6),
                                   "WallLeft": (-2, w0, h0, h1), "WallRight": (w1, 2, h0, h1)}.items():
        rs._quad(scene, name, [(2, ya, za), (2, ya, zb), (2, yb, zb), (2, yb, za)], white)
    sun = rs._sun(scene, 4.0)
    elevation, azimuth = math.radians(35.0), math.radians(15.0)
    _aimed(sun, (-math.cos(elevation) * math.cos(azimuth), -math.cos(elevation) * math.sin(azimuth),
                 -math.sin(elevation)))
    rs._camera(scene, (-1.85, -1.75, 1.5), (1.0, 0.6, 0.7), lens=16.0)
    return scene


def build_emissive_table():
    scene = _scene()
    rs._world(scene, (0.0, 0.0, 0.0), 0.0)
    white = rs._lambert("White", (0.8, 0.8, 0.8))
    _room(scene, (-3, -3, 0), (3, 2, 3), {"White": white,
                                          "Floor": rs._lambert("Floor", (0.5, 0.5, 0.5))},
          skip=("Ceiling", "WallYn", "WallXp"))
    wood = rs._material("Wood", (0.45, 0.25, 0.12), roughness=0.5)
    _box(scene, "TableTop", (0.0, 0.0, 0.72), (1.4, 0.8, 0.05), wood)
    for i, (x, y) in enumerate(((-0.62, -0.32), (0.62, -0.32), (0.62, 0.32), (-0.62, 0.32))):
        _box(scene, f"Leg{i}", (x, y, 0.0), (0.06, 0.06, 0.72), wood)
    rs._sphere(scene, "Sphere", (0.2, 0.05, 0.95), 0.18, rs._material("Blue", (0.1, 0.2, 0.7), 0.3))
    rs._quad(scene, "Panel", [(-0.6, -0.3, 1.9), (-0.6, 0.3, 1.9), (0.6, 0.3, 1.9), (0.6, -0.3, 1.9)],
             _emission("Panel", 8.0))
    rs._camera(scene, (1.0, -2.3, 1.55), (0.0, 0.15, 0.85), lens=30.0)
    return scene


def build_glass_sphere():
    scene = _scene()
    rs._world(scene, (0.2, 0.35, 0.8), 1.0)
    checker = rs._lambert("Checker")
    tree = checker.node_tree
    node = tree.nodes.new("ShaderNodeTexChecker")
    node.inputs["Scale"].default_value = 8.0
    node.inputs["Color1"].default_value = (0.8, 0.8, 0.8, 1.0)
    node.inputs["Color2"].default_value = (0.05, 0.05, 0.05, 1.0)
    tree.links.new(node.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    rs._quad(scene, "Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], checker)
    glass = rs._material("Glass", (1.0, 1.0, 1.0), roughness=0.0,
                         **{"Transmission Weight": 1.0, "IOR": 1.45})
    rs._sphere(scene, "GlassSphere", (0.0, 0.0, 0.5), 0.5, glass)
    sun = rs._sun(scene, 3.0)
    _aimed(sun, (0.45, 0.55, -0.7))
    rs._camera(scene, (0.0, -3.2, 1.4), (0.0, 0.0, 0.35), lens=45.0)
    return scene


def build_glossy_floor():
    scene = _scene()
    rs._world(scene, (0.0, 0.0, 0.0), 0.0)
    floor = rs._material("DarkGloss", (0.03, 0.03, 0.03), roughness=0.15)
    rs._quad(scene, "Floor", [(-6, -6, 0), (6, -6, 0), (6, 8, 0), (-6, 8, 0)], floor)
    gold = rs._material("Gold", (1.0, 0.766, 0.336), roughness=0.25, metallic=1.0)
    rs._sphere(scene, "GoldSphere", (0.7, 0.3, 0.35), 0.35, gold)
    _area(scene, "Strip", (2.0, 0.4), 60.0, (0.0, 1.5, 1.4))
    rs._camera(scene, (0.0, -4.0, 0.35), (0.0, 1.0, -0.35), lens=40.0)
    return scene


BUILDERS = {"cornell_box": build_cornell_box, "sunlit_room": build_sunlit_room,
            "emissive_table": build_emissive_table, "glass_sphere": build_glass_sphere,
            "glossy_floor": build_glossy_floor}


def build(name):
    """The shot `name` of SHOTS, current in this Blender session (factory-empty first)."""
    scene = BUILDERS[name]()
    import bpy
    bpy.context.view_layer.update()
    return scene
