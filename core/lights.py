"""Light kinds: the one table. The exporter maps Blender's lights through it to UsdLux
schemas, and the engine maps UsdLux prims back and picks each kind's shading,
light volume and shadow layout from it. Kinds are these six names everywhere: the
sixth, a polygon, is no UsdLux prim and no Blender light but one polygon of a mesh
whose material emits (engine/emitters.py), shaded as an area light."""
from __future__ import annotations

from dataclasses import dataclass

POINT, SPOT, SUN, RECT, DISK, POLYGON = "point", "spot", "sun", "rect", "disk", "polygon"


@dataclass(frozen=True)
class LightKind:
    name: str
    usd_schema: str        # the UsdLux schema the stage contract writes it as ("": none)
    blender_type: str      # bpy.types.Light.type ("": none)
    blender_shapes: tuple  # area lights: the Blender shapes written as this kind
    positional: bool       # has a position: a light volume and a radial shadow map
    area: bool             # emits from a polygon (rect, disk, an emissive polygon)
    shader: str            # light.frag variant that shades it


KINDS = {k.name: k for k in (
    LightKind(POINT, "SphereLight", "POINT", (), True, False, "LIGHT_SPHERE"),
    LightKind(SPOT, "SphereLight", "SPOT", (), True, False, "LIGHT_SPOT"),  # + ShapingAPI
    LightKind(SUN, "DistantLight", "SUN", (), False, False, "LIGHT_DISTANT"),
    LightKind(RECT, "RectLight", "AREA", ("SQUARE", "RECTANGLE"), True, True, "LIGHT_AREA"),
    LightKind(DISK, "DiskLight", "AREA", ("DISK", "ELLIPSE"), True, True, "LIGHT_AREA"),
    LightKind(POLYGON, "", "", (), True, True, "LIGHT_AREA"),
)}


def kind_of_blender(light_type: str, shape: str | None = None) -> str:
    """The kind of a Blender light (`light.type`, and `light.shape` for area lights)."""
    for kind in KINDS.values():
        if kind.blender_type and kind.blender_type == light_type and (not kind.blender_shapes or shape in kind.blender_shapes):
            return kind.name
    raise ValueError(f"unknown Blender light type {light_type!r} (shape {shape!r})")


def kind_of_usd(schema: str, spot: bool = False) -> str | None:
    """The kind of a UsdLux prim type (`spot`: a SphereLight shaped into a cone), or
    None for schemas Lantern does not draw as a light (DomeLight is the environment)."""
    if schema == "SphereLight":
        return SPOT if spot else POINT
    for kind in KINDS.values():
        if kind.usd_schema and kind.usd_schema == schema and kind.name not in (POINT, SPOT):
            return kind.name
    return None
