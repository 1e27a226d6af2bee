"""A Blender light -> LightRecord, per the contract's light table (kinds: core.lights)."""
import math

from ...core.lights import DISK, POINT, RECT, SPOT, SUN, kind_of_blender
from ..ir import LightRecord


def lantern_settings(light):
    """The light's Lantern settings (shadow resolution, shadow bias) as the .blend stores
    them, so `lantern export`, which never registers the add-on, reads what F12 reads.
    Blender keeps add-on properties in the ID's system properties (5.0+) or among its
    custom properties (4.x), and stores only values that were set."""
    store = light.bl_system_properties_get() if hasattr(light, "bl_system_properties_get") else light
    stored = (store.get("lantern") if store is not None else None) or {}
    return (int(stored.get("shadow_resolution", LightRecord.shadow_resolution)),
            float(stored.get("shadow_bias", LightRecord.shadow_bias)))


def gather_light(light, warn):
    power = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    color = tuple(float(c) for c in light.color)
    if getattr(light, "use_temperature", False):
        color = tuple(c * float(t) for c, t in zip(color, light.temperature_color))
    kind = kind_of_blender(light.type, getattr(light, "shape", None))
    rec = LightRecord(kind=kind, color=color, intensity=power / math.pi,
                      shadow=bool(light.use_shadow),
                      diffuse=float(light.diffuse_factor), specular=float(light.specular_factor))
    if rec.shadow:
        rec.shadow_resolution, rec.shadow_bias = lantern_settings(light)
    if kind in (POINT, SPOT):
        rec.radius = float(light.shadow_soft_size)
        rec.soft_falloff = bool(getattr(light, "use_soft_falloff", True))
    if kind == SPOT:
        rec.cone_angle = math.degrees(float(light.spot_size)) / 2.0
        rec.cone_softness = float(light.spot_blend)
    elif kind == SUN:
        rec.intensity = power  # strength is irradiance in W/m^2
        rec.angle = math.degrees(float(light.angle))
    elif kind in (RECT, DISK):
        sx = float(light.size)
        sy = float(light.size_y) if light.shape in {"RECTANGLE", "ELLIPSE"} else sx
        rec.width, rec.height = sx, sy
        if kind == RECT:
            area = sx * sy
        else:
            # A disk of diameter sx, stretched to sy along y for an ellipse (its prim's
            # xform: exporters/usd/light.py ellipse_scale).
            rec.radius = sx / 2.0
            area = math.pi * sx * sy / 4.0
        if not getattr(light, "normalize", True):
            # Unnormalized: the power is per unit area, so the total grows with the size.
            rec.intensity *= area
    return rec
