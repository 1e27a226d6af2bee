"""The curves scene (docs/stage_contract.md "Curves"): every BasisCurves basis and
wrap, widths that vary (vertex and varying), and curves with and without normals, over
a ground that takes their shadows. `write_stage` writes it as USD with plain pxr (what
Lantern renders, tests/test_curves.py); `build_blender` makes the same curves as
Blender Curves objects for Cycles (references/make_prim_references.py --curves),
each in Blender's own terms of the USD definition, not through Blender's USD importer,
which reads nonperiodic Catmull-Rom curves as pinned ones, pinned B-splines as
nonperiodic ones and drops normals:
- linear: POLY (cyclic where periodic);
- bezier: BEZIER, its knots and free handles the USD points, varying widths as the
  knots' radii (Blender interpolates radii linearly between knots, as USD varying);
- bspline: NURBS of order 4, uniform knots (cyclic where periodic), a pinned one with
  USD's phantom points (2 P0 - P1, 2 Pn-1 - Pn-2) added as control points;
- catmullRom: BEZIER segments with the Catmull-Rom tangents (b1 = P1 + (P2 - P0) / 6,
  b2 = P2 - (P3 - P1) / 6), phantom points added where pinned: Blender's own
  Catmull-Rom type differs from USD at the ends.
Cycles renders a Curves object's control points as an open Catmull-Rom curve whatever
its type and cyclic flag, so each curve goes to Cycles through Blender's own
evaluation: a Resample Curve node (Evaluated, RESOLUTION points a segment) gives the
points on the curve with their radii, and Cycles gets those as an open polyline
(closed by repeating its first point), through which its Catmull-Rom passes.
Cycles draws every curve as a round tube (its 3D curves); Lantern draws those with
authored normals as ribbons facing them, so their bound is stated on its own."""
import math

SIZE = (256, 160)
SAMPLES = 512
SUN = 3.0
SUN_ROTATION = (25.0, 0.0, 40.0)
WORLD = (0.25, 0.25, 0.25)
CAMERA = ((0.0, -3.0, 14.0), (0.0, 0.0, 0.0), 50.0)
GROUND = -0.45                       # the ground plane's height
BASE = (0.85, 0.55, 0.2)
GROUND_BASE = (0.6, 0.6, 0.6)
CELL = (2.6, 2.2)                    # a curve's cell in the grid, 4 across
RESOLUTION = 32                      # Blender's evaluated points a segment

_ZIG = [(-1.0, -0.6, 0.0), (-0.6, 0.6, 0.3), (-0.2, -0.5, 0.0), (0.2, 0.6, 0.2),
        (0.6, -0.5, 0.0), (1.0, 0.5, 0.1), (1.0, -0.6, 0.0)]
_RING = [(math.cos(a) * 0.9, math.sin(a) * 0.7, 0.15 * math.sin(3 * a))
         for a in [2 * math.pi * i / 6 for i in range(6)]]
_WIDTHS7 = [0.06, 0.12, 0.2, 0.12, 0.08, 0.16, 0.1]
_WIDTHS6 = [0.08, 0.16, 0.1, 0.2, 0.06, 0.12]

# name -> (type, basis, wrap, points, widths, widths interpolation, normals or None)
CURVES = {
    "linear": ("linear", None, "nonperiodic", _ZIG[:6], _WIDTHS6, "vertex", None),
    "linear_periodic": ("linear", None, "periodic", _RING, [0.1], "constant", None),
    "bezier": ("cubic", "bezier", "nonperiodic", _ZIG, [0.06, 0.2, 0.1], "varying", None),
    "bezier_periodic": ("cubic", "bezier", "periodic", _RING, [0.08, 0.16], "varying", None),
    "bspline": ("cubic", "bspline", "nonperiodic", _ZIG, _WIDTHS7, "vertex", None),
    "bspline_periodic": ("cubic", "bspline", "periodic", _RING, _WIDTHS6, "vertex", None),
    "bspline_pinned": ("cubic", "bspline", "pinned", _ZIG[:6], _WIDTHS6, "vertex", None),
    "catmullRom": ("cubic", "catmullRom", "nonperiodic", _ZIG, _WIDTHS7, "vertex", None),
    "catmullRom_periodic": ("cubic", "catmullRom", "periodic", _RING, [0.12], "constant", None),
    "catmullRom_pinned": ("cubic", "catmullRom", "pinned", _ZIG[:6], _WIDTHS6, "vertex", None),
    "ribbon_linear": ("linear", None, "nonperiodic", _ZIG[:6], [0.2], "constant",
                      [(0.0, 0.0, 1.0)]),
    "ribbon_catmullRom": ("cubic", "catmullRom", "pinned", _ZIG[:6], _WIDTHS6, "vertex",
                          [(0.0, 0.0, 1.0)]),
}
WITH_NORMALS = [name for name, c in CURVES.items() if c[6] is not None]


def cell_origin(i):
    columns = 4
    rows = (len(CURVES) + columns - 1) // columns
    x = (i % columns - (columns - 1) / 2) * CELL[0]
    y = ((rows - 1) / 2 - i // columns) * CELL[1]
    return x, y


def write_stage(path):
    """The scene as USD (Lantern's reading of it is under test); returns the path."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/root")
    stage.SetDefaultPrim(root.GetPrim())

    def material(name, colour):
        m = UsdShade.Material.Define(stage, f"/root/Materials/{name}")
        s = UsdShade.Shader.Define(stage, f"/root/Materials/{name}/Surface")
        s.CreateIdAttr("UsdPreviewSurface")
        s.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*colour))
        s.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
        s.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
        m.CreateSurfaceOutput().ConnectToSource(s.ConnectableAPI(), "surface")
        return m

    hair, ground_mat = material("Curves", BASE), material("Ground", GROUND_BASE)
    for i, (name, (kind, basis, wrap, pts, widths, interp, normals)) in enumerate(CURVES.items()):
        ox, oy = cell_origin(i)
        c = UsdGeom.BasisCurves.Define(stage, f"/root/{name}")
        c.CreateTypeAttr(kind)
        if basis:
            c.CreateBasisAttr(basis)
        c.CreateWrapAttr(wrap)
        c.CreateCurveVertexCountsAttr([len(pts)])
        c.CreatePointsAttr([Gf.Vec3f(x + ox, y + oy, z) for x, y, z in pts])
        c.CreateWidthsAttr(list(widths))
        c.SetWidthsInterpolation(interp)
        if normals is not None:
            c.CreateNormalsAttr([Gf.Vec3f(*n) for n in normals])
            c.SetNormalsInterpolation(UsdGeom.Tokens.constant)
        UsdShade.MaterialBindingAPI.Apply(c.GetPrim()).Bind(hair)
    ground = UsdGeom.Mesh.Define(stage, "/root/Ground")
    ground.CreateSubdivisionSchemeAttr("none")
    w, h = CELL[0] * 2.6, CELL[1] * 2.2
    ground.CreatePointsAttr([(-w, -h, GROUND), (w, -h, GROUND), (w, h, GROUND), (-w, h, GROUND)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdShade.MaterialBindingAPI.Apply(ground.GetPrim()).Bind(ground_mat)
    eye, target, lens = CAMERA
    cam = UsdGeom.Camera.Define(stage, "/root/Camera")
    cam.CreateFocalLengthAttr(lens)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(36.0 * SIZE[1] / SIZE[0])
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    look = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(0, 0, 1))
    cam.AddTransformOp().Set(look.GetInverse())
    sun = UsdLux.DistantLight.Define(stage, "/root/Sun")
    sun.CreateIntensityAttr(SUN)
    sun.CreateAngleAttr(0.0)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(*SUN_ROTATION))
    dome = UsdLux.DomeLight.Define(stage, "/root/World")
    dome.CreateColorAttr(Gf.Vec3f(*WORLD))
    stage.GetRootLayer().Save()
    return path


def _pad(pts):
    """USD's pinned phantom points around a list of points."""
    first = tuple(2 * a - b for a, b in zip(pts[0], pts[1]))
    last = tuple(2 * a - b for a, b in zip(pts[-1], pts[-2]))
    return [first] + list(pts) + [last]


def _catmull_rom_beziers(pts, closed):
    """[(b0, b1, b2, b3)] of each Catmull-Rom segment P1 -> P2."""
    n = len(pts)
    out = []
    for i in range(n if closed else n - 3):
        p0, p1, p2, p3 = (pts[(i + k) % n] for k in range(4))
        b1 = tuple(a + (c - b) / 6 for a, b, c in zip(p1, p0, p2))
        b2 = tuple(a - (c - b) / 6 for a, b, c in zip(p2, p1, p3))
        out.append((p1, b1, b2, p2))
    return out


def _bezier_knots(segments, closed):
    """Blender Bezier points (co, left handle, right handle) of joined segments."""
    knots = []
    for i, (b0, b1, b2, b3) in enumerate(segments):
        if i == 0:
            knots.append([b0, b0, b1])
        else:
            knots[-1][2] = b1
        knots.append([b3, b2, b3])
    if closed:                       # the last knot is the first
        first = knots.pop(0)
        knots[-1][2] = first[2]
    return knots


def _resample():
    """A geometry-nodes group: each curve as the polyline of its evaluated points."""
    import bpy
    group = bpy.data.node_groups.get("Resample")
    if group is not None:
        return group
    group = bpy.data.node_groups.new("Resample", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    source, sink = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    resample = group.nodes.new("GeometryNodeResampleCurve")
    resample.inputs["Mode"].default_value = "Evaluated"
    group.links.new(source.outputs[0], resample.inputs["Curve"])
    group.links.new(resample.outputs[0], sink.inputs[0])
    return group


def evaluated(ob):
    """(points (n, 3), radii (n,), cyclic) of a Curves object as Blender evaluates it
    (a Resample Curve node, Evaluated, read and taken off again)."""
    import bpy
    import numpy as np
    modifier = ob.modifiers.new("Resample", "NODES")
    modifier.node_group = _resample()
    try:
        data = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        cyclic = data.attributes.get("cyclic")
        return (np.array([p.position for p in data.points]),
                np.array([p.radius for p in data.points]), bool(cyclic and cyclic.data[0].value))
    finally:
        ob.modifiers.remove(modifier)


def _as_polylines(scene, material):
    """Every curve object replaced by the open polyline of its evaluated points."""
    import bpy
    for name in CURVES:
        ob = bpy.data.objects[name]
        points, radii, cyclic = evaluated(ob)
        if cyclic:
            points, radii = list(points) + [points[0]], list(radii) + [radii[0]]
        bpy.data.objects.remove(ob)
        data = bpy.data.hair_curves.new(name + "_evaluated")
        data.add_curves([len(points)])
        data.set_types(type="POLY")
        radius = data.attributes.new("radius", "FLOAT", "POINT")
        for j, (p, r) in enumerate(zip(points, radii)):
            data.points[j].position, radius.data[j].value = tuple(p), float(r)
        data.materials.append(material)
        scene.collection.objects.link(bpy.data.objects.new(name, data))


def build_blender(evaluate=True):
    """The same scene as Blender objects; returns the scene. `evaluate`: the curves as
    the polylines Cycles gets (else as Blender's own curve types)."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100

    def material(name, colour):
        m = bpy.data.materials.new(name)
        bsdf = m.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
        bsdf.inputs["Roughness"].default_value = 1.0
        bsdf.inputs["Specular IOR Level"].default_value = 0.0
        return m

    hair = material("Curves", BASE)
    for i, (name, (kind, basis, wrap, pts, widths, interp, _)) in enumerate(CURVES.items()):
        ox, oy = cell_origin(i)
        pts = [(x + ox, y + oy, z) for x, y, z in pts]
        closed = wrap == "periodic"
        radii = [w / 2 for w in widths]
        data = bpy.data.hair_curves.new(name)
        if kind == "linear" or basis == "bspline":
            if basis == "bspline" and wrap == "pinned":
                pts = _pad(pts)
                radii = [max(r[0], 0.0) for r in _pad([(r,) for r in radii])]
            data.add_curves([len(pts)])
            data.set_types(type="POLY" if kind == "linear" else "NURBS")
            if basis == "bspline":
                data.attributes.new("nurbs_order", "INT8", "CURVE").data[0].value = 4
            positions = pts
        else:
            if basis == "catmullRom":
                src = _pad(pts) if wrap == "pinned" else pts
                segments = _catmull_rom_beziers(src, closed)
                if interp == "vertex":       # radii at the knots: P1 .. Pn-2 (pinned: all)
                    src_r = radii if wrap == "pinned" else radii[1:-1]
                    radii = src_r if not closed else radii
            else:
                n = len(pts)
                step = range(0, n if closed else n - 1, 3)
                segments = [tuple(pts[(j + k) % n] for k in range(4)) for j in step]
            knots = _bezier_knots(segments, closed)
            data.add_curves([len(knots)])
            data.set_types(type="BEZIER")
            positions = [k[0] for k in knots]
            left = data.attributes.new("handle_left", "FLOAT_VECTOR", "POINT")
            right = data.attributes.new("handle_right", "FLOAT_VECTOR", "POINT")
            for side in ("left", "right"):          # free handles: where they are put
                data.attributes.new(f"handle_type_{side}", "INT8", "POINT")
            for j, (_, lh, rh) in enumerate(knots):
                left.data[j].vector, right.data[j].vector = lh, rh
            if len(radii) == 1:
                radii = radii * len(knots)
            elif closed and basis == "bezier":
                radii = radii[1:] + radii[:1]    # the first knot is now the last
        for j, p in enumerate(positions):
            data.points[j].position = p
        radius = data.attributes.new("radius", "FLOAT", "POINT")
        for j in range(len(positions)):
            radius.data[j].value = radii[j] if len(radii) > 1 else radii[0]
        if closed:
            data.attributes.new("cyclic", "BOOLEAN", "CURVE").data[0].value = True
        data.attributes.new("resolution", "INT", "CURVE").data[0].value = RESOLUTION
        ob = bpy.data.objects.new(name, data)
        scene.collection.objects.link(ob)
    if evaluate:
        _as_polylines(scene, hair)
    w, h = CELL[0] * 2.6, CELL[1] * 2.2
    mesh = bpy.data.meshes.new("Ground")
    mesh.from_pydata([(-w, -h, GROUND), (w, -h, GROUND), (w, h, GROUND), (-w, h, GROUND)],
                     [], [(0, 1, 2, 3)])
    mesh.materials.append(material("Ground", GROUND_BASE))
    ground = bpy.data.objects.new("Ground", mesh)
    scene.collection.objects.link(ground)
    from mathutils import Vector
    eye, target, lens = CAMERA
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens, cam.data.sensor_width, cam.data.sensor_fit = lens, 36.0, 'HORIZONTAL'
    cam.data.clip_start, cam.data.clip_end = 0.1, 100.0
    cam.location = eye
    cam.rotation_euler = (Vector(target) - Vector(eye)).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy, sun.data.angle = SUN, 0.0
    sun.rotation_euler = tuple(math.radians(a) for a in SUN_ROTATION)
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("World")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*WORLD, 1.0)
    scene.world = world
    return scene


# --- a Blender hair system ------------------------------------------------------------

HAIR_SIZE = (160, 120)
HAIR_STRANDS = 12                    # a side: strands in a square patch


def build_hair(hidden=False):
    """A patch of Catmull-Rom hair strands (Blender's hair type), thinning to the tips,
    with a material, over a ground under a sun: a Blender scene, returned. `hidden`:
    the hair is not rendered (the same scene without it)."""
    import bpy
    import numpy as np
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = HAIR_SIZE
    scene.render.resolution_percentage = 100
    scene.cycles.max_bounces = 0     # direct light, as its Cycles reference is lit
    rng = np.random.default_rng(7)
    n, k = HAIR_STRANDS * HAIR_STRANDS, 8
    data = bpy.data.hair_curves.new("Hair")
    data.add_curves([k] * n)
    roots = np.stack(np.meshgrid(np.linspace(-0.8, 0.8, HAIR_STRANDS),
                                 np.linspace(-0.8, 0.8, HAIR_STRANDS)), -1).reshape(-1, 2)
    roots += rng.uniform(-0.04, 0.04, roots.shape)
    t = np.linspace(0.0, 1.0, k)
    phase = rng.uniform(0, 2 * np.pi, n)
    x = roots[:, :1] + 0.12 * np.sin(5 * t[None] + phase[:, None]) * t[None]
    y = roots[:, 1:] + 0.35 * t[None] ** 2
    z = 0.9 * t[None] * np.ones((n, 1))
    positions = np.stack([x, y, z], -1).astype(np.float32).reshape(-1, 3)
    data.attributes["position"].data.foreach_set("vector", positions.ravel())
    radius = data.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", np.tile(np.linspace(0.018, 0.006, k), n).astype(np.float32))
    hair = bpy.data.materials.new("HairMaterial")
    bsdf = hair.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.75, 0.45, 0.15, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.6
    data.materials.append(hair)
    ob = bpy.data.objects.new("Hair", data)
    ob.hide_render = hidden
    scene.collection.objects.link(ob)
    mesh = bpy.data.meshes.new("Ground")
    mesh.from_pydata([(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], [], [(0, 1, 2, 3)])
    scene.collection.objects.link(bpy.data.objects.new("Ground", mesh))
    from mathutils import Vector
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -4.0, 2.2)
    cam.rotation_euler = (Vector((0, 0, 0.4)) - cam.location).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = SUN
    sun.rotation_euler = tuple(math.radians(a) for a in (35.0, 0.0, 30.0))
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("World")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*WORLD, 1.0)
    scene.world = world
    return scene
