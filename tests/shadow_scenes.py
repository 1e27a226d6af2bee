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
    """A stage with the white material and a ground plane of that half size (None: no
    ground)."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    mat = white_material(stage)
    if half is None:
        return stage
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
    """An axis-aligned box with flat (faceVarying) normals; size: its edge, or its
    three edges."""
    s = np.asarray(size, float) / 2
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
               ortho_width=None):
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateFocalLengthAttr(focal)
    if ortho_width is not None:
        cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
        cam.CreateHorizontalApertureAttr(ortho_width * 10)
        cam.CreateVerticalApertureAttr(ortho_width * 10 / aspect)
    else:
        cam.CreateHorizontalApertureAttr(hap)
        cam.CreateVerticalApertureAttr(hap / aspect)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.05, far))
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(0, 0, 1))
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


def _quad(stage, name, corners, normal, double_sided):
    """A quad wound counter-clockwise about `normal` (its front face)."""
    corners = np.asarray(corners, float)
    if np.dot(np.cross(corners[1] - corners[0], corners[2] - corners[1]), normal) < 0:
        corners = corners[::-1]
    mesh = UsdGeom.Mesh.Define(stage, f"/root/{name}")
    mesh.CreatePointsAttr([tuple(map(float, c)) for c in corners])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateNormalsAttr([tuple(map(float, normal))] * 4)
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateDoubleSidedAttr(bool(double_sided))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath("/root/_materials/white")))
    return mesh


def add_room(stage, half=(2.0, 1.5), height=2.5, thickness=0.0, double_sided=False,
             window=None):
    """A closed room centred on the origin, floor at z = 0: floor, ceiling and four
    walls, each a separate mesh meeting its neighbours at seams. thickness 0: each is
    one quad facing into the room (single- or double-sided); otherwise a box of that
    thickness outside the room's inner faces (the boxes overlap at the corners, as
    modelled walls do). window: (x0, x1, z0, z1) of an opening in the +Y wall (quads
    around it)."""
    hx, hy = half
    if thickness > 0:
        t = thickness
        boxes = {"floor": ((-hx - t, -hy - t, -t), (hx + t, hy + t, 0.0)),
                 "ceiling": ((-hx - t, -hy - t, height), (hx + t, hy + t, height + t)),
                 "wall_px": ((hx, -hy - t, 0.0), (hx + t, hy + t, height)),
                 "wall_nx": ((-hx - t, -hy - t, 0.0), (-hx, hy + t, height)),
                 "wall_ny": ((-hx, -hy - t, 0.0), (hx, -hy, height))}
        if window is None:
            boxes["wall_py"] = ((-hx, hy, 0.0), (hx, hy + t, height))
        else:
            x0, x1, z0, z1 = window
            boxes.update({"wall_py_left": ((-hx, hy, 0.0), (x0, hy + t, height)),
                          "wall_py_right": ((x1, hy, 0.0), (hx, hy + t, height)),
                          "wall_py_below": ((x0, hy, 0.0), (x1, hy + t, z0)),
                          "wall_py_above": ((x0, hy, z1), (x1, hy + t, height))})
        for name, (lo, hi) in boxes.items():
            lo, hi = np.asarray(lo, float), np.asarray(hi, float)
            add_box(stage, center=tuple((lo + hi) / 2), size=hi - lo, name=name)
        return
    quads = {"floor": ([(-hx, -hy, 0), (hx, -hy, 0), (hx, hy, 0), (-hx, hy, 0)], (0, 0, 1)),
             "ceiling": ([(-hx, -hy, height), (-hx, hy, height), (hx, hy, height),
                          (hx, -hy, height)], (0, 0, -1)),
             "wall_px": ([(hx, -hy, 0), (hx, hy, 0), (hx, hy, height), (hx, -hy, height)], (-1, 0, 0)),
             "wall_nx": ([(-hx, -hy, 0), (-hx, -hy, height), (-hx, hy, height), (-hx, hy, 0)], (1, 0, 0)),
             "wall_ny": ([(-hx, -hy, 0), (-hx, -hy, height), (hx, -hy, height), (hx, -hy, 0)], (0, 1, 0))}
    py = (0, -1, 0)
    if window is None:
        quads["wall_py"] = ([(-hx, hy, 0), (hx, hy, 0), (hx, hy, height), (-hx, hy, height)], py)
    else:
        x0, x1, z0, z1 = window
        for name, (a, b, c, d) in {"left": (-hx, x0, 0, height), "right": (x1, hx, 0, height),
                                   "below": (x0, x1, 0, z0), "above": (x0, x1, z1, height)}.items():
            quads[f"wall_py_{name}"] = ([(a, hy, c), (b, hy, c), (b, hy, d), (a, hy, d)], py)
    for name, (corners, normal) in quads.items():
        _quad(stage, name, corners, normal, double_sided)
