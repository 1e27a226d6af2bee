"""A stage like Blender's default scene, made in memory: what the engine host renders
to warm up before Blender asks for its first frame (engine/host/warmup.py)."""
from __future__ import annotations

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

CUBE_POINTS = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
CUBE_FACES = [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5]


def default_scene():
    """An in-memory stage: a cube with a UsdPreviewSurface, a point light with shadows,
    Blender's default world (a uniform dome) and a camera, as the exporter writes them
    (docs/stage_contract.md)."""
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.z)
    cube = UsdGeom.Mesh.Define(s, "/root/Cube")
    cube.CreatePointsAttr([Gf.Vec3f(*p) for p in CUBE_POINTS])
    cube.CreateFaceVertexCountsAttr([4] * 6)
    cube.CreateFaceVertexIndicesAttr(CUBE_FACES)
    material = UsdShade.Material.Define(s, "/root/Material")
    shader = UsdShade.Shader.Define(s, "/root/Material/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.8, 0.8, 0.8))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.5)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(cube.GetPrim()).Bind(material)
    light = UsdLux.SphereLight.Define(s, "/root/Light")
    light.CreateIntensityAttr(100.0)
    light.CreateRadiusAttr(0.1)
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(4.0, 1.0, 6.0))
    UsdLux.ShadowAPI.Apply(light.GetPrim()).CreateShadowEnableAttr(True)
    world = UsdLux.DomeLight.Define(s, "/root/_world")
    world.CreateColorAttr(Gf.Vec3f(0.05, 0.05, 0.05))
    camera = UsdGeom.Camera.Define(s, "/root/Camera")
    camera.AddTranslateOp().Set(Gf.Vec3d(7.0, -7.0, 5.0))
    camera.AddRotateXYZOp().Set(Gf.Vec3f(63.0, 0.0, 45.0))
    return s
