"""Scene settings for Lantern, stored on `scene.lantern`."""
import bpy

PRESETS = (
    ("low", "Low", "Fastest: smallest shadow maps and fewest filter taps"),
    ("medium", "Medium", "Balanced quality and speed"),
    ("high", "High", "Larger shadow maps and softer filtering"),
    ("ultra", "Ultra", "Closest to Cycles, slowest"),
)


class LanternSceneSettings(bpy.types.PropertyGroup):
    preset: bpy.props.EnumProperty(
        name="Quality", items=PRESETS, default="medium",
        description="Trades render time for error against Cycles")


def register():
    bpy.utils.register_class(LanternSceneSettings)
    bpy.types.Scene.lantern = bpy.props.PointerProperty(type=LanternSceneSettings)


def unregister():
    del bpy.types.Scene.lantern
    bpy.utils.unregister_class(LanternSceneSettings)
