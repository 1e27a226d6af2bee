"""A white Lambert plane under a black world, seen straight down, lit by a rect light or by
an emissive panel of the same size and power (tests/test_emitters.py,
bench/bench_emitters.py)."""
import numpy as np
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

import shadow_scenes

W, H = 64, 48
CAM_Z = 4.0
FOCAL, HAP = 20.0, 36.0
CENTRE, SIZE, INTENSITY = np.array([0.3, 0.2, 1.5]), (1.2, 0.8), 50.0
FORMS = {"volumes": dict(lighting="volumes", compute=False),
         "clustered": dict(lighting="clustered", light_error=0.0)}


def stage_with(light: str, sampling: str = "", facing: float = -1.0, cells: int = 1):
    """The white plane under a black world, seen straight down, lit by a rect light
    ("rect"), or by an emissive panel ("quad") of the rect's size and radiance, a grid
    of cells x cells quads, whose normals point along z = `facing`, its material's
    emission sampling `sampling` (unauthored: Cycles' Auto)."""
    stage = shadow_scenes.new_stage(20.0)
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateFocalLengthAttr(FOCAL)
    cam.CreateHorizontalApertureAttr(HAP)
    cam.CreateVerticalApertureAttr(HAP * H / W)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    cam.AddTranslateOp().Set((0, 0, CAM_Z))
    UsdLux.DomeLight.Define(stage, "/root/world").CreateColorAttr(Gf.Vec3f(0, 0, 0))
    w, h = SIZE
    if light == "rect":
        rect = UsdLux.RectLight.Define(stage, "/root/rect")
        rect.CreateIntensityAttr(INTENSITY)
        rect.CreateNormalizeAttr(True)
        rect.CreateWidthAttr(w)
        rect.CreateHeightAttr(h)
        rect.AddTranslateOp().Set(Gf.Vec3d(*CENTRE))
        return stage
    mat = UsdShade.Material.Define(stage, "/root/glow")
    surface = UsdShade.Shader.Define(stage, "/root/glow/surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    L = INTENSITY / (w * h)
    surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(L, L, L))
    mat.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    if sampling:
        mat.GetPrim().CreateAttribute("lantern:emissionSampling", Sdf.ValueTypeNames.Token,
                                      custom=True).Set(sampling)
    quad = UsdGeom.Mesh.Define(stage, "/root/panel")
    quad.CreateSubdivisionSchemeAttr("none")
    # cells x cells quads, wound counter-clockwise about their normals
    xs, ys = np.linspace(-w / 2, w / 2, cells + 1), np.linspace(-h / 2, h / 2, cells + 1)
    quad.CreatePointsAttr([(x, y, 0.0) for y in ys for x in xs])
    faces = []
    for j in range(cells):
        for i in range(cells):
            a = j * (cells + 1) + i
            face = [a, a + 1, a + cells + 2, a + cells + 1]
            faces += face[::-1] if facing < 0 else face
    quad.CreateFaceVertexCountsAttr([4] * cells * cells)
    quad.CreateFaceVertexIndicesAttr(faces)
    quad.CreateNormalsAttr([(0, 0, facing)] * (cells + 1) ** 2)
    quad.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    quad.AddTranslateOp().Set(Gf.Vec3d(*CENTRE))
    UsdShade.MaterialBindingAPI.Apply(quad.GetPrim()).Bind(mat)
    return stage


def plane_mask():
    """Pixels that see the plane past the quad's place (the quad hides the rest)."""
    j = (np.arange(W) + 0.5) / W * 2 - 1
    i = 1 - (np.arange(H) + 0.5) / H * 2
    X, Y = np.meshgrid(j * (HAP / 2) / FOCAL * CAM_Z, i * (HAP * H / W / 2) / FOCAL * CAM_Z)
    t = (CAM_Z - CENTRE[2]) / CAM_Z           # where the ray to the plane crosses the quad
    inside = (np.abs(X * t - CENTRE[0]) < SIZE[0] / 2 + 0.1) & \
        (np.abs(Y * t - CENTRE[1]) < SIZE[1] / 2 + 0.1)
    return ~inside
