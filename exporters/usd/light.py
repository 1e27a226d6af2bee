"""LightRecord -> UsdLux light on the object prim (the schema from core.lights)."""
from pxr import Gf, Sdf, UsdGeom, UsdLux

from ...core.lights import DISK, KINDS, POINT, RECT, SPOT, SUN
from ..ir import LightRecord


def write_light(stage, path, rec):
    light = getattr(UsdLux, KINDS[rec.kind].usd_schema).Define(stage, path)
    if rec.kind in (POINT, SPOT):
        light.CreateRadiusAttr(rec.radius)
        light.CreateTreatAsPointAttr(rec.radius == 0.0)
        light.GetPrim().CreateAttribute("lantern:softFalloff", Sdf.ValueTypeNames.Bool,
                                        custom=True).Set(rec.soft_falloff)
        if rec.kind == SPOT:
            shaping = UsdLux.ShapingAPI.Apply(light.GetPrim())
            shaping.CreateShapingConeAngleAttr(rec.cone_angle)
            shaping.CreateShapingConeSoftnessAttr(rec.cone_softness)
    elif rec.kind == SUN:
        light.CreateAngleAttr(rec.angle)
    elif rec.kind == RECT:
        light.CreateWidthAttr(rec.width)
        light.CreateHeightAttr(rec.height)
    else:
        light.CreateRadiusAttr(rec.radius)
    write_common(light, rec.color, rec.intensity, rec.shadow, rec.diffuse, rec.specular)
    _write_shadow_settings(light.GetPrim(), rec)
    return light


def write_ellipse_scale(prim, rec):
    """An ellipse: UsdLux has no such light, so it is its DiskLight (radius half its
    x size) stretched along y by a scale op after the object's own transform
    (docs/stage_contract.md), which any UsdLux reader applies to the disk. Blender's
    own USD exporter writes the disk unstretched."""
    if rec.kind == DISK and rec.height != rec.width:
        UsdGeom.Xformable(prim).AddScaleOp(UsdGeom.XformOp.PrecisionDouble, "ellipse").Set(
            Gf.Vec3d(1.0, rec.height / rec.width, 1.0))


def _write_shadow_settings(prim, rec):
    """Lantern's shadow overrides, authored only where they differ from the defaults."""
    if rec.shadow_resolution != LightRecord.shadow_resolution:
        prim.CreateAttribute("lantern:shadowResolution", Sdf.ValueTypeNames.Int,
                             custom=True).Set(int(rec.shadow_resolution))
    if rec.shadow_bias != LightRecord.shadow_bias:
        prim.CreateAttribute("lantern:shadowBias", Sdf.ValueTypeNames.Float,
                             custom=True).Set(float(rec.shadow_bias))


def write_common(light, color, intensity, shadow, diffuse=1.0, specular=1.0):
    api = UsdLux.LightAPI(light.GetPrim())
    api.CreateNormalizeAttr(True)
    api.CreateColorAttr(Gf.Vec3f(*color))
    api.CreateIntensityAttr(float(intensity))
    api.CreateDiffuseAttr(float(diffuse))
    api.CreateSpecularAttr(float(specular))
    UsdLux.ShadowAPI.Apply(light.GetPrim()).CreateShadowEnableAttr(bool(shadow))
