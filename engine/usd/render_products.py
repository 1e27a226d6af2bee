"""UsdRender on the stage: the RenderSettings prim a render uses, its RenderProducts
(one output file each) and their RenderVars (the file's layers), as plain records.

Which RenderSettings: the one asked for (`lantern render --settings PRIM`), else the
stage's `renderSettingsPrimPath` metadata, else none. A product's own resolution and
camera, where authored, override its settings' (UsdRender's SettingsBase), as
`husk` reads them. What each RenderVar's `sourceName` means is core/passes.py's
(`resolve`): the command line says what Lantern cannot make."""
from __future__ import annotations

from dataclasses import dataclass

from pxr import Sdf, UsdRender

VIEW_LAYER = "lantern:viewLayer"     # a product's Blender view layer (the file's layer names)
DEFAULT_VIEW_LAYER = "ViewLayer"


@dataclass(frozen=True)
class RenderVar:
    path: str                # the RenderVar prim
    source: str              # sourceName: an AOV or pass name
    source_type: str         # raw, primvar, lpe or intrinsic


@dataclass(frozen=True)
class RenderProduct:
    path: str                # the RenderProduct prim
    name: str                # productName as authored: a file, maybe with $F4-style tokens
    product_type: str        # raster, deepRaster, ...
    resolution: tuple | None  # (width, height): the product's, else its settings', else None
    camera: str | None       # likewise
    vars: tuple              # RenderVar, in orderedVars order
    view_layer: str = DEFAULT_VIEW_LAYER


class RenderSettingsError(ValueError):
    """A RenderSettings prim that cannot be used: the message names the prim."""


def settings_path(stage, asked: str | None = None) -> str | None:
    """The RenderSettings prim a render uses: `asked`, else the stage's
    renderSettingsPrimPath metadata, else None. An asked-for or named prim that is not
    a RenderSettings is a RenderSettingsError."""
    path = asked
    if path is None and stage.HasAuthoredMetadata("renderSettingsPrimPath"):
        path = stage.GetMetadata("renderSettingsPrimPath") or None
    if path is None:
        return None
    where = "--settings" if asked is not None else "renderSettingsPrimPath"
    if not Sdf.Path.IsValidPathString(path) or not Sdf.Path(path).IsAbsolutePath():
        raise RenderSettingsError(f"{where} {path}: not an absolute prim path")
    prim = stage.GetPrimAtPath(path)
    if not prim:
        raise RenderSettingsError(f"{where} {path}: the stage has no such prim")
    if not prim.IsA(UsdRender.Settings):
        raise RenderSettingsError(f"{where} {path}: is a {prim.GetTypeName() or 'typeless prim'}, "
                                  "not a RenderSettings")
    return path


def _authored(attr):
    return attr.Get() if attr and attr.HasAuthoredValue() else None


def _camera(rel):
    targets = rel.GetForwardedTargets() if rel else []
    return str(targets[0]) if targets else None


@dataclass(frozen=True)
class RenderSettingsRecord:
    path: str
    resolution: tuple | None   # (width, height) if authored
    camera: str | None         # the camera relationship's first target
    products: tuple            # RenderProduct


def read_settings(stage, path: str) -> tuple:
    """(RenderSettingsRecord, warnings) of the RenderSettings prim at `path`: a
    products target that is not a RenderProduct, or an orderedVars target that is not
    a RenderVar, is a warning naming it, and is left out."""
    settings = UsdRender.Settings(stage.GetPrimAtPath(path))
    base_res = _authored(settings.GetResolutionAttr())
    base_camera = _camera(settings.GetCameraRel())
    products, warnings = [], []
    for target in settings.GetProductsRel().GetForwardedTargets():
        prim = stage.GetPrimAtPath(target)
        if not prim or not prim.IsA(UsdRender.Product):
            warnings.append(f"{path}: its product {target} is not a RenderProduct; skipped")
            continue
        product = UsdRender.Product(prim)
        variables = []
        for var_path in product.GetOrderedVarsRel().GetForwardedTargets():
            var = stage.GetPrimAtPath(var_path)
            if not var or not var.IsA(UsdRender.Var):
                warnings.append(f"{target}: its render var {var_path} is not a RenderVar; "
                                "skipped")
                continue
            v = UsdRender.Var(var)
            variables.append(RenderVar(str(var_path), str(v.GetSourceNameAttr().Get() or ""),
                                       str(v.GetSourceTypeAttr().Get() or "raw")))
        res = _authored(product.GetResolutionAttr())
        res = res if res is not None else base_res
        layer = prim.GetAttribute(VIEW_LAYER)
        products.append(RenderProduct(
            path=str(target), name=str(product.GetProductNameAttr().Get() or ""),
            product_type=str(product.GetProductTypeAttr().Get() or "raster"),
            resolution=(int(res[0]), int(res[1])) if res is not None else None,
            camera=_camera(product.GetCameraRel()) or base_camera, vars=tuple(variables),
            view_layer=str(layer.Get()) if layer and layer.HasAuthoredValue()
            else DEFAULT_VIEW_LAYER))
    return RenderSettingsRecord(path, (int(base_res[0]), int(base_res[1]))
                                if base_res is not None else None, base_camera,
                                tuple(products)), warnings
