"""Stages made in memory that the engine host renders to warm up before Blender asks
for its first frame (engine/host/warmup.py): one like Blender's default scene, and
one with the features a first frame commonly needs besides (light kinds, image
textures, a normal map, skinning)."""
from __future__ import annotations

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdSkel

from ...core.lights import KINDS, SPOT

CUBE_POINTS = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
CUBE_FACES = [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5]
FEATURE_NORMAL_MAPPED = "/root/NormalMapped"


def default_scene():
    """An in-memory stage: a cube with a UsdPreviewSurface, a point light with shadows,
    Blender's default world (a uniform dome) and a camera, as the exporter writes them
    (docs/stage_contract.md)."""
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.z)
    cube = _cube(s, "/root/Cube")
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


def feature_scene(texture: str):
    """The default scene with what else a first frame commonly needs made: a light of
    every kind (core/lights.py), shadowed, and an unshadowed one; a cube whose base
    colour is `texture` (an image file), a cube normal-mapped by it (deactivate
    FEATURE_NORMAL_MAPPED to draw without one: a normal map changes every lighting
    program), and a skinned quad. engine/host/warmup.py renders it."""
    s = default_scene()
    for i, kind in enumerate(k for k in KINDS.values() if k.usd_schema):
        light = getattr(UsdLux, kind.usd_schema).Define(s, f"/root/Light_{kind.name}")
        light.CreateIntensityAttr(10.0)
        if kind.name == SPOT:
            UsdLux.ShapingAPI.Apply(light.GetPrim()).CreateShapingConeAngleAttr(30.0)
        UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(-3.0 + 1.5 * i, -2.0, 5.0))
        UsdLux.ShadowAPI.Apply(light.GetPrim()).CreateShadowEnableAttr(True)
    UsdLux.SphereLight.Define(s, "/root/Light_unshadowed").CreateIntensityAttr(10.0)
    for name, slot in (("Textured", "diffuseColor"), ("NormalMapped", "normal")):
        cube = _cube(s, f"/root/{name}", offset=3.0 if slot == "normal" else -3.0)
        uv = UsdGeom.PrimvarsAPI(cube).CreatePrimvar("UVMap", Sdf.ValueTypeNames.TexCoord2fArray,
                                                     UsdGeom.Tokens.faceVarying)
        uv.Set([(0, 0), (1, 0), (1, 1), (0, 1)] * 6)
        material = UsdShade.Material.Define(s, f"/root/{name}_material")
        surface = UsdShade.Shader.Define(s, f"/root/{name}_material/Surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        reader = UsdShade.Shader.Define(s, f"/root/{name}_material/uv")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("UVMap")
        image = UsdShade.Shader.Define(s, f"/root/{name}_material/image")
        image.CreateIdAttr("UsdUVTexture")
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(texture)
        image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
            reader.ConnectableAPI(), "result")
        kind = Sdf.ValueTypeNames.Normal3f if slot == "normal" else Sdf.ValueTypeNames.Color3f
        if slot == "normal":
            image.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
            image.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set((2, 2, 2, 1))
            image.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set((-1, -1, -1, 0))
        surface.CreateInput(slot, kind).ConnectToSource(image.ConnectableAPI(), "rgb")
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(cube.GetPrim()).Bind(material)
    _skinned_quad(s, "/root/Skinned")
    return s


def _cube(s, path, offset=0.0):
    """Blender's default cube at `path`, moved `offset` along y."""
    cube = UsdGeom.Mesh.Define(s, path)
    cube.CreateSubdivisionSchemeAttr("none")
    cube.CreatePointsAttr([Gf.Vec3f(x, y + offset, z) for x, y, z in CUBE_POINTS])
    cube.CreateFaceVertexCountsAttr([4] * 6)
    cube.CreateFaceVertexIndicesAttr(CUBE_FACES)
    return cube


def _skinned_quad(s, path):
    root = UsdSkel.Root.Define(s, path)
    skeleton = UsdSkel.Skeleton.Define(s, f"{path}/Skeleton")
    skeleton.CreateJointsAttr(["bone"])
    skeleton.CreateBindTransformsAttr([Gf.Matrix4d(1.0)])
    skeleton.CreateRestTransformsAttr([Gf.Matrix4d(1.0)])
    animation = UsdSkel.Animation.Define(s, f"{path}/Skeleton/Pose")
    animation.CreateJointsAttr(["bone"])
    animation.CreateTranslationsAttr([Gf.Vec3f(0.0, 0.0, 0.0)])
    animation.CreateRotationsAttr([Gf.Quatf(1.0)])
    animation.CreateScalesAttr([Gf.Vec3h(1.0, 1.0, 1.0)])
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets(
        [animation.GetPath()])
    UsdSkel.BindingAPI.Apply(root.GetPrim()).CreateSkeletonRel().SetTargets([skeleton.GetPath()])
    mesh = UsdGeom.Mesh.Define(s, f"{path}/Mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([Gf.Vec3f(x, y, 2.0) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateJointIndicesPrimvar(False, 1).Set([0] * 4)
    binding.CreateJointWeightsPrimvar(False, 1).Set([1.0] * 4)
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))
