"""Transparency test scenes, built in memory with pxr following the stage contract.

- `planes`: three overlapping, double-sided planes at z = 0, 1, 2 (4, 3 and 2 m
  wide, all over the z axis), each only emitting (red, green, blue; black diffuse, no
  specular) and see-through with opacity `alpha`, no other light (a black dome).
  Along the z axis the image is the "over" composite of the three, so the order is
  checked in closed form (`composite`).
- `shadow_layers`: a white floor lit by a sun along (1, 0, -1); two see-through
  planes (opacity `alpha`) at z = 1 and z = 2 over x in [-1, 1], the first over
  y in [-2, 0], the second over y in [-1, 1]. A looking-down orthographic camera sees
  their shadows side by side on the floor at x in [1, 2] (shifted by their heights),
  where neither plane is in the way: one layer over y in [-2, -1] and [0, 1], two
  over y in [-1, 0].
"""
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

COLOURS = {"red": (1.0, 0.0, 0.0), "green": (0.0, 1.0, 0.0), "blue": (0.0, 0.0, 1.0)}
HEIGHTS = {"red": 0.0, "green": 1.0, "blue": 2.0}
SIZES = {"red": 4.0, "green": 3.0, "blue": 2.0}


def _stage():
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    return stage


def material(stage, name, diffuse=(0, 0, 0), emissive=(0, 0, 0), opacity=1.0,
             threshold=0.0, alpha_mode=""):
    mat = UsdShade.Material.Define(stage, f"/root/_materials/{name}")
    sh = UsdShade.Shader.Define(stage, f"/root/_materials/{name}/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*diffuse))
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*emissive))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    sh.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(opacity)
    if threshold:
        sh.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(threshold)
    if alpha_mode:
        mat.GetPrim().CreateAttribute("lantern:alphaMode", Sdf.ValueTypeNames.Token).Set(alpha_mode)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def quad(stage, path, x, y, z, mat, normal=(0, 0, 1)):
    """An axis-aligned rectangle [x0, x1] x [y0, y1] at height z, double-sided."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([Gf.Vec3f(x[0], y[0], z), Gf.Vec3f(x[1], y[0], z),
                           Gf.Vec3f(x[1], y[1], z), Gf.Vec3f(x[0], y[1], z)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateNormalsAttr([Gf.Vec3f(*normal)] * 4)
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateDoubleSidedAttr(True)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    return mesh


def camera(stage, eye, target, up=(0, 0, 1), ortho_width=None, aspect=16 / 9):
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateFocalLengthAttr(35.0)
    if ortho_width is not None:
        cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
        cam.CreateHorizontalApertureAttr(ortho_width * 10)
        cam.CreateVerticalApertureAttr(ortho_width * 10 / aspect)
    else:
        cam.CreateHorizontalApertureAttr(36.0)
        cam.CreateVerticalApertureAttr(36.0 / aspect)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.05, 100.0))
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(*up))
    cam.AddTransformOp().Set(m.GetInverse())
    return cam


def planes(eye, up=(0, 0, 1), alpha=0.5, alpha_mode=""):
    stage = _stage()
    dome = UsdLux.DomeLight.Define(stage, "/root/_world")
    dome.CreateIntensityAttr(0.0)
    for name, colour in COLOURS.items():
        half, z = SIZES[name] / 2, HEIGHTS[name]
        mat = material(stage, name, emissive=colour, opacity=alpha, alpha_mode=alpha_mode)
        quad(stage, f"/root/{name}", (-half, half), (-half, half), z, mat)
    camera(stage, eye, (0.0, 0.0, 1.0), up)
    return stage


def composite(eye, alpha=0.5):
    """(rgb, alpha) along the ray from `eye` through (0, 0, 1): the planes composited
    "over", nearest first."""
    eye = np.asarray(eye, float)
    target = np.array([0.0, 0.0, 1.0])
    order = sorted(COLOURS, key=lambda n: abs(eye[2] - HEIGHTS[n]) / abs(eye[2] - target[2]))
    rgb, transmit = np.zeros(3), 1.0
    for name in order:
        rgb += transmit * alpha * np.array(COLOURS[name])
        transmit *= 1.0 - alpha
    return rgb, 1.0 - transmit


def shadow_layers(alpha=0.5, preset_size=None):
    stage = _stage()
    white = material(stage, "white", diffuse=(1, 1, 1))
    quad(stage, "/root/floor", (-6, 6), (-6, 6), 0.0, white)
    see = material(stage, "glass", diffuse=(0.5, 0.5, 0.5), opacity=alpha)
    quad(stage, "/root/low", (-1, 1), (-2, 0), 1.0, see)
    quad(stage, "/root/high", (-1, 1), (-1, 1), 2.0, see)
    sun = UsdLux.DistantLight.Define(stage, "/root/sun")
    sun.CreateIntensityAttr(3.0)
    sun.CreateAngleAttr(0.0)
    sun.CreateNormalizeAttr(True)
    UsdLux.ShadowAPI.Apply(sun.GetPrim()).CreateShadowEnableAttr(True)
    d = np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, 0, 0), Gf.Vec3d(*d), Gf.Vec3d(0, 0, 1))
    sun.AddTransformOp().Set(m.GetInverse())
    camera(stage, (1.5, -0.5, 10.0), (1.5, -0.5, 0.0), up=(0, 1, 0), ortho_width=3.2,
           aspect=1.0)
    return stage


def floor_region(image, x, y, centre=(1.5, -0.5), width=3.2):
    """Mean of `image` (H, W, C, row 0 = +y) over floor rectangle x, y (world) seen by
    shadow_layers' camera."""
    h, w = image.shape[:2]
    cols = lambda a: int(round((a - centre[0] + width / 2) / width * w))  # noqa: E731
    rows = lambda b: int(round((centre[1] + width / 2 - b) / width * h))  # noqa: E731
    return image[rows(y[1]):rows(y[0]), cols(x[0]):cols(x[1])].mean(axis=(0, 1))
