"""Scene settings for Lantern, stored on `scene.lantern`."""
import bpy

from ..core.presets import DEFAULT, PRESETS as QUALITY

PRESETS = tuple((p.name, p.label, p.description) for p in QUALITY.values())


class LanternSceneSettings(bpy.types.PropertyGroup):
    preset: bpy.props.EnumProperty(
        name="Quality", items=PRESETS, default=DEFAULT,
        description="Trades render time for error against Cycles")


def register():
    bpy.utils.register_class(LanternSceneSettings)
    bpy.types.Scene.lantern = bpy.props.PointerProperty(type=LanternSceneSettings)


def unregister():
    del bpy.types.Scene.lantern
    bpy.utils.unregister_class(LanternSceneSettings)
