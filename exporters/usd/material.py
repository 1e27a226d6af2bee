"""MaterialRecord -> UsdShade.Material with a UsdPreviewSurface network, and its
pattern graph (if any) as a MaterialX-style network on the `mtlx` render context."""
from pxr import Gf, Sdf, UsdShade

from ...core.emission import DEFAULT as DEFAULT_SAMPLING
from ..ir import TexInput
from .names import primvar_name

INPUT_TYPES = {
    "diffuseColor": Sdf.ValueTypeNames.Color3f,
    "emissiveColor": Sdf.ValueTypeNames.Color3f,
    "normal": Sdf.ValueTypeNames.Normal3f,
}
OUTPUT_TYPES = {"rgb": Sdf.ValueTypeNames.Float3}
# MaterialX's ND_UsdPreviewSurface_surfaceshader types its normal float3.
MTLX_INPUT_TYPES = {**INPUT_TYPES, "normal": Sdf.ValueTypeNames.Float3}
# How a see-through material is drawn when UsdPreviewSurface alone cannot say (the
# stage contract, "Material"): "hashed" for Blender's Dithered render method.
ALPHA_MODE = "lantern:alphaMode"
BUMP_CORRECTION = "lantern:bumpMapCorrection"
EMISSION_SAMPLING = "lantern:emissionSampling"
BASE_OCCLUSION = "lantern:baseColorOcclusion"
# The share of light a surface lets through as glass (contract: "Glass").
TRANSMISSION = "lantern:transmission"
# A UsdUVTexture's interpolation, where not linear (contract: "Textures").
FILTERTYPE = "lantern:filtertype"
# A sheen lobe (contract: "Sheen"; core/sheen.py its modes).
SHEEN = (("lantern:sheenMode", Sdf.ValueTypeNames.Token),
         ("lantern:sheenColor", Sdf.ValueTypeNames.Color3f),
         ("lantern:sheenRoughness", Sdf.ValueTypeNames.Float))


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
        key = (tex.file, tex.uv, tex.wrap, tex.color_space, tex.scale, tex.bias, tex.filtertype)
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
            if tex.filtertype != "linear":
                shader.GetPrim().CreateAttribute(FILTERTYPE, Sdf.ValueTypeNames.Token,
                                                 custom=True).Set(tex.filtertype)
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
    if rec.graph is not None:
        write_pattern(stage, path, material, surface, rec.graph, asset_path)
    if rec.alpha_mode:
        material.GetPrim().CreateAttribute(ALPHA_MODE, Sdf.ValueTypeNames.Token,
                                           custom=True).Set(rec.alpha_mode)
    if not rec.bump_correction:            # authored only where it differs from Cycles' default
        material.GetPrim().CreateAttribute(BUMP_CORRECTION, Sdf.ValueTypeNames.Bool,
                                           custom=True).Set(False)
    if rec.emission_sampling != DEFAULT_SAMPLING:   # authored only where not Cycles' default
        material.GetPrim().CreateAttribute(EMISSION_SAMPLING, Sdf.ValueTypeNames.Token,
                                           custom=True).Set(rec.emission_sampling)
    if rec.base_occlusion:
        material.GetPrim().CreateAttribute(BASE_OCCLUSION, Sdf.ValueTypeNames.Bool,
                                           custom=True).Set(True)
    if rec.transmission > 0.0:
        material.GetPrim().CreateAttribute(TRANSMISSION, Sdf.ValueTypeNames.Float,
                                           custom=True).Set(float(rec.transmission))
    if rec.sheen is not None:
        sheen = rec.sheen
        for (name, kind), value in zip(SHEEN, (sheen.mode, Gf.Vec3f(*sheen.color),
                                               sheen.roughness)):
            material.GetPrim().CreateAttribute(name, kind, custom=True).Set(value)
    return material


# PatternNode value types -> USD value types (docs/stage_contract.md, "Pattern graph").
PATTERN_TYPES = {"float": Sdf.ValueTypeNames.Float, "vector": Sdf.ValueTypeNames.Vector3f,
                 "color": Sdf.ValueTypeNames.Color3f, "float[]": Sdf.ValueTypeNames.FloatArray,
                 "color4[]": Sdf.ValueTypeNames.Color4fArray, "asset": Sdf.ValueTypeNames.Asset}
MTLX_SURFACE = "ND_UsdPreviewSurface_surfaceshader"
# A pattern node's MaterialX node-definition name. Not `info:id`: no Sdr registry has
# Lantern's definitions, and UsdValidation reports an unregistered id as an error.
NODE_DEF = "lantern:nodeDef"


def _pattern_value(typ, value):
    if typ == "color4[]":
        return [Gf.Vec4f(*c) for c in value]
    if typ in ("vector", "color"):
        return Gf.Vec3f(*value)
    return value


def write_pattern(stage, path, material, preview, graph, asset_path):
    """The graph as a NodeGraph `Pattern` of shaders named by `lantern:nodeDef`
    ND_lantern_<kind> (settings are string inputs, values typed inputs, links
    connections), read by an
    ND_UsdPreviewSurface_surfaceshader on `outputs:mtlx:surface` whose unconnected
    inputs are the UsdPreviewSurface's."""
    ng = UsdShade.NodeGraph.Define(stage, path.AppendChild("Pattern"))
    shaders = {}
    for node in graph.nodes:
        shader = UsdShade.Shader.Define(stage, ng.GetPath().AppendChild(node.name))
        shader.GetPrim().CreateAttribute(NODE_DEF, Sdf.ValueTypeNames.Token,
                                         custom=True).Set(f"ND_lantern_{node.kind}")
        for name, value in sorted(node.settings.items()):
            shader.CreateInput(name, Sdf.ValueTypeNames.String).Set(str(value))
        for name, (typ, value) in sorted(node.values.items()):
            value = asset_path(value) if typ == "asset" else _pattern_value(typ, value)
            shader.CreateInput(name, PATTERN_TYPES[typ]).Set(value)
        for name, typ in sorted(node.outputs.items()):
            shader.CreateOutput(name, PATTERN_TYPES[typ])
        for name, (typ, src, out) in sorted(node.links.items()):
            shader.CreateInput(name, PATTERN_TYPES[typ]).ConnectToSource(
                shaders[src].GetOutput(out))
        shaders[node.name] = shader
    mtlx = UsdShade.Shader.Define(stage, path.AppendChild("MtlxSurface"))
    mtlx.CreateIdAttr(MTLX_SURFACE)
    for inp in preview.GetInputs():
        if not inp.HasConnectedSource() and inp.GetBaseName() not in graph.outputs:
            mtlx.CreateInput(inp.GetBaseName(), inp.GetTypeName()).Set(inp.Get())
    for target, (src, out) in sorted(graph.outputs.items()):
        src_out = shaders[src].GetOutput(out)
        typ = MTLX_INPUT_TYPES.get(target, Sdf.ValueTypeNames.Float)
        ng_out = ng.CreateOutput(target, src_out.GetTypeName())
        ng_out.ConnectToSource(src_out)
        mtlx.CreateInput(target, typ).ConnectToSource(ng_out)
    material.CreateSurfaceOutput("mtlx").ConnectToSource(mtlx.ConnectableAPI(), "surface")
