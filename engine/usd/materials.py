"""UsdPreviewSurface networks -> Material records, named by the Material prim's path.

Each input is a constant or a UsdUVTexture output (clearcoat and clearcoatRoughness:
constants only, as the exporter writes them) (connections are followed through
material interface inputs with GetValueProducingAttributes). A texture whose file is
missing gives a warning naming the material and the path, and the input keeps its
constant value (or the UsdPreviewSurface default)."""
from __future__ import annotations

import math
import os

import numpy as np
from pxr import Usd, UsdShade

from ...core.emission import SAMPLING
from ...core.images import DEFAULT_FILTERTYPE, filtertype_of
from ...core.sheen import MODES as SHEEN_MODES
from ..scene import Material, TextureRef
from .patterns import read_pattern

DEFAULTS = {
    "diffuseColor": (0.18, 0.18, 0.18), "metallic": 0.0, "roughness": 0.5, "ior": 1.5,
    "emissiveColor": (0.0, 0.0, 0.0), "opacity": 1.0, "opacityThreshold": 0.0,
    "clearcoat": 0.0, "clearcoatRoughness": 0.01,
}
FIELDS = {"diffuseColor": "diffuse", "metallic": "metallic", "roughness": "roughness",
          "ior": "ior", "emissiveColor": "emissive", "opacity": "opacity",
          "opacityThreshold": "opacity_threshold", "clearcoat": "clearcoat",
          "clearcoatRoughness": "clearcoat_roughness"}
MAPPABLE = ("diffuseColor", "metallic", "roughness", "emissiveColor", "opacity", "normal")


def default_material(display_color=None, display_opacity=None) -> Material:
    """A gprim without a bound material: UsdPreviewSurface's defaults, in the gprim's
    displayColor and displayOpacity (their first values) when it has them (named by
    them, so equal ones share a record), as Storm's fallback surface draws it."""
    opacity = 1.0 if display_opacity is None else float(display_opacity)
    if not math.isfinite(opacity):
        opacity = 1.0
    if display_color is None and opacity == 1.0:
        return Material(name="<default>")
    diffuse = Material().diffuse if display_color is None else \
        tuple(float(c) for c in display_color)
    name = "<displayColor %r %r %r>" % diffuse
    if opacity != 1.0:
        name = name[:-1] + " opacity %r>" % opacity
    return Material(name=name, diffuse=diffuse, opacity=min(max(opacity, 0.0), 1.0))


def _shader_id(shader: UsdShade.Shader) -> str:
    return str(shader.GetIdAttr().Get() or "")


def _source(inp: UsdShade.Input, time):
    """(value, None) or (None, (shader, output name))."""
    attrs = inp.GetValueProducingAttributes()
    if attrs:
        a = attrs[0]
        if UsdShade.Output.IsOutput(a):
            return None, (UsdShade.Shader(a.GetPrim()), a.GetBaseName())
        return a.Get(time), None
    return inp.Get(time), None


def _input_value(shader, name, time, default=None):
    inp = shader.GetInput(name)
    if not inp:
        return default
    v, _ = _source(inp, time)
    return default if v is None else v


def _uv_name(tex_shader, time):
    inp = tex_shader.GetInput("st")
    if not inp:
        return None
    _, src = _source(inp, time)
    if src is None:
        return None
    reader = src[0]
    if not _shader_id(reader).startswith("UsdPrimvarReader"):
        return None
    v = _input_value(reader, "varname", time)
    return str(v) if v else None


def _read_emission_sampling(prim, out: Material, warnings: list):
    """lantern:emissionSampling (docs/stage_contract.md, "Emission")."""
    sampling = prim.GetAttribute("lantern:emissionSampling")
    if not sampling or not sampling.HasAuthoredValue():
        return
    value = str(sampling.Get())
    if value not in SAMPLING:
        warnings.append(f"{prim.GetPath()}: lantern:emissionSampling {value!r} is not one "
                        f"of {', '.join(SAMPLING)}; using {out.emission_sampling!r}")
        return
    out.emission_sampling = value


def _read_sheen(prim, out: Material, time, warnings: list):
    """lantern:sheenMode, sheenColor, sheenRoughness (docs/stage_contract.md, "Sheen")."""
    mode = prim.GetAttribute("lantern:sheenMode")
    if not mode or not mode.HasAuthoredValue():
        return
    mode = str(mode.Get(time))
    if mode not in SHEEN_MODES:
        warnings.append(f"{prim.GetPath()}: lantern:sheenMode {mode!r} is not one of "
                        f"{', '.join(SHEEN_MODES)}; no sheen")
        return
    color = prim.GetAttribute("lantern:sheenColor")
    roughness = prim.GetAttribute("lantern:sheenRoughness")
    out.sheen_mode = mode
    if color and color.HasAuthoredValue():
        out.sheen = tuple(float(c) for c in color.Get(time))
    if roughness and roughness.HasAuthoredValue():
        out.sheen_roughness = float(roughness.Get(time))


def _read_transmission(prim, out: Material, time, warnings: list):
    """lantern:transmission (docs/stage_contract.md, "Glass"), in [0, 1]."""
    attr = prim.GetAttribute("lantern:transmission")
    if not attr or not attr.HasAuthoredValue():
        return
    value = float(attr.Get(time))
    if not 0.0 <= value <= 1.0:
        warnings.append(f"{prim.GetPath()}: lantern:transmission {value!r} is not in "
                        f"[0, 1]; clamped")
        value = min(max(value, 0.0), 1.0) if math.isfinite(value) else 0.0
    out.transmission = value


def read_material(mat: UsdShade.Material, time, warnings: list) -> Material:
    path = str(mat.GetPath())
    out = Material(name=path)
    index = mat.GetPrim().GetAttribute("lantern:passIndex")
    if index and index.HasAuthoredValue():
        out.pass_index = int(index.Get())        # render pass IndexMA
    mode = mat.GetPrim().GetAttribute("lantern:alphaMode")
    if mode and mode.HasAuthoredValue():
        out.alpha_mode = str(mode.Get())         # see Material.alpha
    correction = mat.GetPrim().GetAttribute("lantern:bumpMapCorrection")
    if correction and correction.HasAuthoredValue():
        out.bump_correction = bool(correction.Get())
    occlusion = mat.GetPrim().GetAttribute("lantern:baseColorOcclusion")
    if occlusion and occlusion.HasAuthoredValue():
        out.base_occlusion = bool(occlusion.Get())
    _read_sheen(mat.GetPrim(), out, time, warnings)
    _read_transmission(mat.GetPrim(), out, time, warnings)
    _read_emission_sampling(mat.GetPrim(), out, warnings)
    surface = mat.ComputeSurfaceSource()[0]
    if not surface or _shader_id(surface) != "UsdPreviewSurface":
        warnings.append(f"{path}: no UsdPreviewSurface surface; using the default material")
        return out
    for name in list(DEFAULTS) + ["normal"]:
        inp = surface.GetInput(name)
        if not inp:
            continue
        value, src = _source(inp, time)
        if src is None and not inp.HasConnectedSource() and inp.GetAttr().HasAuthoredConnections():
            targets = ", ".join(str(t) for t in inp.GetAttr().GetConnections())
            warnings.append(f"{path}: input {name} is connected to {targets}, which does "
                            f"not exist; using its value or default")
        if src is not None:
            tex_shader, channel = src
            if _shader_id(tex_shader) != "UsdUVTexture" or name not in MAPPABLE:
                warnings.append(f"{path}: input {name} is connected to an unsupported "
                                f"node {tex_shader.GetPath()}; using its constant value")
            else:
                ref = _texture_ref(tex_shader, channel, time, path, warnings)
                if ref is not None:
                    out.maps[name] = ref
                    if out.uv_name is None:
                        out.uv_name = _uv_name(tex_shader, time)
            value = inp.Get(time)  # constant fallback if authored alongside
        if value is not None and name in FIELDS:
            if isinstance(DEFAULTS[name], tuple):
                value = tuple(float(c) for c in value)
            else:
                value = float(value)
            if not all(math.isfinite(c) for c in np.atleast_1d(value)):
                warnings.append(f"{path}: input {name} is not finite ({value}); using the "
                                f"default {DEFAULTS[name]}")
                continue
            setattr(out, FIELDS[name], value)
    out.pattern = read_pattern(mat, time, warnings)
    if out.transmission > 0.0:
        # `opacity` says "translucent" to other readers (1 - transmission): glass is
        # drawn whole, its see-through share by the glass pass.
        out.opacity = 1.0
        out.opacity_threshold = 0.0
        out.maps.pop("opacity", None)
    return out


def _texture_ref(shader, channel, time, mat_path, warnings):
    asset = _input_value(shader, "file", time)
    if asset is None or not asset.path:
        warnings.append(f"{mat_path}: texture {shader.GetPath()} has no file; using the "
                        f"constant fallback")
        return None
    tiles = _udim_tiles(shader, asset.path)
    resolved = tiles[0][1] if tiles else asset.resolvedPath
    if not resolved or not os.path.isfile(resolved):
        warnings.append(f"{mat_path}: texture file {asset.path!r} not found; using the "
                        f"constant fallback")
        return None
    filtertype = shader.GetPrim().GetAttribute("lantern:filtertype")
    filtertype = filtertype_of(str(filtertype.Get(time)), str(shader.GetPath()), warnings.append) \
        if filtertype and filtertype.HasAuthoredValue() else DEFAULT_FILTERTYPE
    scale = _input_value(shader, "scale", time, (1.0, 1.0, 1.0, 1.0))
    bias = _input_value(shader, "bias", time, (0.0, 0.0, 0.0, 0.0))
    return TextureRef(
        path=resolved,
        colorspace=str(_input_value(shader, "sourceColorSpace", time, "auto")),
        wrap_s=str(_input_value(shader, "wrapS", time, "useMetadata")).replace("useMetadata", "repeat"),
        wrap_t=str(_input_value(shader, "wrapT", time, "useMetadata")).replace("useMetadata", "repeat"),
        scale=tuple(float(c) for c in scale), bias=tuple(float(c) for c in bias),
        channel=channel if channel in ("r", "g", "b", "a") else "rgb", tiles=tiles,
        filtertype=filtertype)


def _udim_tiles(shader, path) -> tuple:
    """((tile, resolved path), ...) of a `<UDIM>` path's tiles on disk, resolved against
    the layer that authored the file input; () for another path."""
    if not UsdShade.UdimUtils.IsUdimIdentifier(path):
        return ()
    attr = shader.GetInput("file").GetAttr()
    specs = attr.GetPropertyStack(Usd.TimeCode.Default())
    layer = specs[0].layer if specs else shader.GetPrim().GetStage().GetRootLayer()
    found = UsdShade.UdimUtils.ResolveUdimTilePaths(path, layer)
    return tuple(sorted((int(tile), resolved) for resolved, tile in found))


def might_vary(mat: UsdShade.Material) -> bool:
    """Whether any value of the material's network may change over time (it is then
    read again at every new time)."""
    for prim in Usd.PrimRange(mat.GetPrim()):
        for attr in prim.GetAuthoredAttributes():
            if attr.ValueMightBeTimeVarying():
                return True
    return False
