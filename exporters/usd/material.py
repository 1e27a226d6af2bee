"""MaterialRecord -> UsdShade.Material with a UsdPreviewSurface network."""
from pxr import Gf, Sdf, UsdShade

from ..ir import TexInput
from .names import primvar_name

INPUT_TYPES = {
    "diffuseColor": Sdf.ValueTypeNames.Color3f,
    "emissiveColor": Sdf.ValueTypeNames.Color3f,
    "normal": Sdf.ValueTypeNames.Normal3f,
}
OUTPUT_TYPES = {"rgb": Sdf.ValueTypeNames.Float3}
# How a see-through material is drawn when UsdPreviewSurface alone cannot say (the
# stage contract, "Material"): "hashed" for Blender's Dithered render method.
ALPHA_MODE = "lantern:alphaMode"


def write_material(stage, path, rec, default_uv, asset_path):
    """`default_uv`: primvar for textures on the render-active UV map;
    `asset_path(file)`: the string written to `inputs:file`."""
    material = UsdShade.Material.Define(stage, path)
    surface = UsdShade.Shader.Define(stage, path.AppendChild("PreviewSurface"))
    surface.CreateIdAttr("UsdPreviewSurface")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")

    textures, readers = {}, {}

    def reader(uv):
        varname = primvar_name(uv) if uv else default_uv
        if varname not in readers:
            shader = UsdShade.Shader.Define(
                stage, path.AppendChild(f"uv_{len(readers)}"))
            shader.CreateIdAttr("UsdPrimvarReader_float2")
            shader.CreateInput("varname", Sdf.ValueTypeNames.String).Set(varname)
            readers[varname] = shader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
        return readers[varname]

    def texture(tex):
        key = (tex.file, tex.uv, tex.wrap, tex.color_space, tex.scale, tex.bias)
        if key not in textures:
            shader = UsdShade.Shader.Define(stage, path.AppendChild(f"tex_{len(textures)}"))
            shader.CreateIdAttr("UsdUVTexture")
            shader.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(asset_path(tex.file))
            shader.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader(tex.uv))
            shader.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(tex.wrap)
            shader.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(tex.wrap)
            shader.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(tex.color_space)
            if tex.scale != (1.0, 1.0, 1.0, 1.0):
                shader.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*tex.scale))
            if tex.bias != (0.0, 0.0, 0.0, 0.0):
                shader.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*tex.bias))
            textures[key] = shader
        return textures[key]

    for name in sorted(rec.inputs):
        value = rec.inputs[name]
        inp = surface.CreateInput(name, INPUT_TYPES.get(name, Sdf.ValueTypeNames.Float))
        if isinstance(value, TexInput):
            shader = texture(value.texture)
            out = shader.CreateOutput(value.channel,
                                      OUTPUT_TYPES.get(value.channel, Sdf.ValueTypeNames.Float))
            inp.ConnectToSource(out)
        elif isinstance(value, tuple):
            inp.Set(Gf.Vec3f(*value))
        else:
            inp.Set(float(value))
    if rec.alpha_mode:
        material.GetPrim().CreateAttribute(ALPHA_MODE, Sdf.ValueTypeNames.Token,
                                           custom=True).Set(rec.alpha_mode)
    return material
