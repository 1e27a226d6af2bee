"""The implicit-surface scenes (docs/stage_contract.md "Implicit surfaces"), one per
UsdGeom type, written as USD with plain pxr: shared by the Cycles reference script
(references/make_prim_references.py, which renders each file through Blender's USD
importer) and by tests/test_implicit.py, which renders the same file with Lantern.

Each scene holds three of its type side by side, one per axis (X, Y, Z) where the
type has one, else three sizes or turns, under one UsdPreviewSurface material, seen
by a camera above the front, lit by a sun and a uniform dome. The lights are written
as Lantern's exporter writes a Blender sun of strength SUN and a world of colour
WORLD; the reference script makes those in Blender (the importer's light conversion
is not under test). `as_mesh` writes every shape as a Mesh prim of the triangles
Lantern makes for it (engine/usd/shapes.py), or of `segments` sides: the matching
mesh scene."""
SIZE = (192, 72)
SAMPLES = 512
SUN = 3.0                                    # W/m2, straight from the sun's rotation
SUN_ROTATION = (40.0, 0.0, 30.0)             # degrees, XYZ Euler (Blender's)
WORLD = (0.25, 0.25, 0.25)
CAMERA = ((0.0, -14.0, 6.0), (0.0, 0.0, 0.0), 50.0)   # eye, target, lens (36 mm wide)
SPACING = 3.0
BASE = (0.8, 0.45, 0.25)
ROUGHNESS = 0.4

# name -> (type name, [(attribute values, rotateXYZ degrees)] left to right)
SCENES = {
    "sphere": ("Sphere", [({"radius": 0.6}, None), ({"radius": 0.8}, None),
                          ({"radius": 1.0}, None)]),
    "cube": ("Cube", [({"size": 1.4}, None), ({"size": 1.4}, (0.0, 0.0, 30.0)),
                      ({"size": 1.4}, (35.0, 20.0, 10.0))]),
    "cylinder": ("Cylinder", [({"radius": 0.6, "height": 1.8, "axis": a}, None) for a in "XYZ"]),
    "cone": ("Cone", [({"radius": 0.8, "height": 1.8, "axis": a}, None) for a in "XYZ"]),
    "capsule": ("Capsule", [({"radius": 0.55, "height": 1.2, "axis": a}, None) for a in "XYZ"]),
    "plane": ("Plane", [({"width": 1.6, "length": 2.2, "axis": a}, (20.0, 0.0, -50.0))
                        for a in "XYZ"]),
    "cylinder_1": ("Cylinder_1", [({"radiusTop": 0.3, "radiusBottom": 0.8, "height": 1.8,
                                    "axis": a}, None) for a in "XYZ"]),
    "capsule_1": ("Capsule_1", [({"radiusTop": 0.35, "radiusBottom": 0.7, "height": 1.2,
                                  "axis": a}, None) for a in "XYZ"]),
}


def write_stage(name, path, as_mesh=False, segments=None):
    """Writes scene `name` to `path` (.usda) and returns the path."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
    type_name, shapes = SCENES[name]
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/root")
    stage.SetDefaultPrim(root.GetPrim())
    material = UsdShade.Material.Define(stage, "/root/Material")
    shader = UsdShade.Shader.Define(stage, "/root/Material/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*BASE))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(ROUGHNESS)
    shader.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.5)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    for i, (attrs, turn) in enumerate(shapes):
        xf = UsdGeom.Xform.Define(stage, f"/root/Shape{i}")
        xf.AddTranslateOp().Set(Gf.Vec3d((i - 1) * SPACING, 0.0, 0.0))
        if turn is not None:
            xf.AddRotateXYZOp().Set(Gf.Vec3f(*turn))
        path_i = f"/root/Shape{i}/{type_name}"
        if as_mesh:
            prim = _mesh(stage, path_i, type_name, attrs, segments)
        else:
            prim = stage.DefinePrim(path_i, type_name)
            for key, value in attrs.items():
                prim.GetAttribute(key).Set(value)
        UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)
    eye, target, lens = CAMERA
    cam = UsdGeom.Camera.Define(stage, "/root/Camera")
    width, height = SIZE
    cam.CreateFocalLengthAttr(lens)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(36.0 * height / width)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    look = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(0, 0, 1))
    cam.AddTransformOp().Set(look.GetInverse())
    sun = UsdLux.DistantLight.Define(stage, "/root/Sun")
    sun.CreateIntensityAttr(SUN)
    sun.CreateAngleAttr(0.0)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(*SUN_ROTATION))
    dome = UsdLux.DomeLight.Define(stage, "/root/World")
    dome.CreateColorAttr(Gf.Vec3f(*WORLD))
    dome.CreateIntensityAttr(1.0)
    stage.GetRootLayer().Save()
    return path


def _mesh(stage, path, type_name, attrs, segments):
    """A Mesh prim of the triangles Lantern makes for the shape (its normals too)."""
    from pxr import UsdGeom, Vt
    from lantern.engine.usd import shapes
    params = (type_name,) + tuple(attrs[k] for k in shapes.SHAPES[type_name])
    surface = shapes.surface(params, segments)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(surface.points.astype("float32")))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(surface.counts.astype("int32")))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(surface.indices.astype("int32")))
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(surface.normals.astype("float32")))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return mesh.GetPrim()

