"""Shadow test scenes, built in memory with pxr following the stage contract: a white
Lambert plane (z = 0), optionally a unit box standing on it, one light, a camera."""
import math

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade


def white_material(stage):
    mat = UsdShade.Material.Define(stage, "/root/_materials/white")
    sh = UsdShade.Shader.Define(stage, "/root/_materials/white/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((1, 1, 1))
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    sh.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def new_stage(half=20.0):
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    mat = white_material(stage)
    mesh = UsdGeom.Mesh.Define(stage, "/root/plane")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateNormalsAttr([(0, 0, 1)] * 4)
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateDoubleSidedAttr(False)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    return stage


def add_box(stage, center=(0, 0, 0.5), size=1.0, name="box"):
    """An axis-aligned box with flat (faceVarying) normals."""
    s = size / 2
    c = np.asarray(center, float)
    faces = [((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
             ((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
             ((0, 1, 0), (0, 0, 1), (1, 0, 0)), ((0, -1, 0), (1, 0, 0), (0, 0, 1))]
    pts, normals = [], []
    for n, u, v in faces:
        n, u, v = (np.asarray(a, float) for a in (n, u, v))
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            pts.append(tuple(c + (n + a * u + b * v) * s))
            normals.append(tuple(n))
    mesh = UsdGeom.Mesh.Define(stage, f"/root/{name}")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(pts)
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr(list(range(24)))
    mesh.CreateNormalsAttr(normals)
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath("/root/_materials/white")))
    return mesh


def add_camera(stage, eye, target, focal=20.0, hap=36.0, aspect=16 / 9, far=200.0,
               ortho_width=None, up=(0, 0, 1), near=0.05):
    """`up`: the image's up, given where the camera looks straight down (along z)."""
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateFocalLengthAttr(focal)
    if ortho_width is not None:
        cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
        cam.CreateHorizontalApertureAttr(ortho_width * 10)
        cam.CreateVerticalApertureAttr(ortho_width * 10 / aspect)
    else:
        cam.CreateHorizontalApertureAttr(hap)
        cam.CreateVerticalApertureAttr(hap / aspect)
    cam.CreateClippingRangeAttr(Gf.Vec2f(near, far))
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(*up))
    cam.AddTransformOp().Set(m.GetInverse())
    return cam


def _place(light, pos, aim=None):
    """Light at pos, its -Z pointing at aim."""
    if aim is None:
        light.AddTranslateOp().Set(Gf.Vec3d(*pos))
        return
    up = (0, 1, 0) if abs(np.asarray(aim, float) - pos)[2] > 1e-9 and \
        np.allclose(np.cross(np.asarray(aim, float) - pos, (0, 1, 0)), 0) is False else (0, 0, 1)
    d = np.asarray(aim, float) - np.asarray(pos, float)
    up = (0, 1, 0) if abs(d[2]) > 0.99 * np.linalg.norm(d) else (0, 0, 1)
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*pos), Gf.Vec3d(*aim), Gf.Vec3d(*up))
    light.AddTransformOp().Set(m.GetInverse())


def add_light(stage, kind, shadow=True, **kw):
    """kind: sun | point | spot | area. kw: pos, aim, power/strength, radius, angle,
    cone (half angle deg), softness, size, resolution, name (prim name, default kind)."""
    path = f"/root/{kw.get('name', kind)}"
    if kind == "sun":
        light = UsdLux.DistantLight.Define(stage, path)
        light.CreateIntensityAttr(kw.get("strength", 3.0))
        light.CreateAngleAttr(kw.get("angle", 0.0))
        d = np.asarray(kw.get("dir", (0, 0, -1)), float)
        _place(light, np.zeros(3), d)
    elif kind in ("point", "spot"):
        light = UsdLux.SphereLight.Define(stage, path)
        light.CreateIntensityAttr(kw.get("power", 1000.0) / math.pi)
        r = kw.get("radius", 0.0)
        light.CreateRadiusAttr(r)
        light.CreateTreatAsPointAttr(r == 0)
        if kind == "spot":
            sh = UsdLux.ShapingAPI.Apply(light.GetPrim())
            sh.CreateShapingConeAngleAttr(kw.get("cone", 30.0))
            sh.CreateShapingConeSoftnessAttr(kw.get("softness", 0.0))
        _place(light, kw["pos"], kw.get("aim") if kind == "spot" else None)
    elif kind == "area":
        light = UsdLux.RectLight.Define(stage, path)
        light.CreateIntensityAttr(kw.get("power", 200.0) / math.pi)
        light.CreateWidthAttr(kw.get("size", 1.0))
        light.CreateHeightAttr(kw.get("size", 1.0))
        _place(light, kw["pos"], kw.get("aim"))
    else:
        raise ValueError(kind)
    light.CreateNormalizeAttr(True)
    UsdLux.ShadowAPI.Apply(light.GetPrim()).CreateShadowEnableAttr(bool(shadow))
    if "resolution" in kw:
        light.GetPrim().CreateAttribute("lantern:shadowResolution",
                                        Sdf.ValueTypeNames.Int).Set(int(kw["resolution"]))
    return light
