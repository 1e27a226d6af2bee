"""Lantern's settings: `scene.lantern` (the render) and `light.lantern` (each light).

Only settings the engine honours today. The quality presets are the engine's own table;
the light defaults are the exporter's LightRecord defaults (both mean "not authored").
"""
import bpy

from ..core.presets import DEFAULT, PRESETS as QUALITY
from ..exporters.ir import LightRecord

PRESETS = tuple((p.name, p.label, p.description) for p in QUALITY.values())


class LanternSceneSettings(bpy.types.PropertyGroup):
    preset: bpy.props.EnumProperty(
        name="Quality", items=PRESETS, default=DEFAULT,
        description="Trades render time for error against Cycles")
    viewport_resolution: bpy.props.FloatProperty(
        name="Viewport Resolution", default=1.0, min=0.1, max=1.0, subtype='FACTOR',
        description="Fraction of the viewport's pixels rendered in Rendered shading "
                    "(drawn stretched): lower is faster")
    subdivision: bpy.props.EnumProperty(
        name="Subdivision", default="APPLY",
        items=(("APPLY", "Apply", "Blender subdivides: the Subdivision Surface modifier's "
                                  "mesh is exported"),
               ("CAGE", "Cage", "Lantern subdivides: a mesh whose last modifier is a "
                                "Catmull-Clark Subdivision Surface is exported as its cage "
                                "and refined by the GPU's tessellation (GL 4.3) or on the "
                                "CPU; a viewport edit then sends the cage")),
        description="Who subdivides Subdivision Surface meshes")
    viewport_stats: bpy.props.BoolProperty(
        name="Statistics", default=False,
        description="Show the frame time, GPU time and draw calls of the latest viewport "
                    "frame in its top-left corner")


class LanternLightSettings(bpy.types.PropertyGroup):
    shadow_resolution: bpy.props.IntProperty(
        name="Resolution", default=LightRecord.shadow_resolution, min=0, max=8192,
        soft_max=4096, subtype='PIXEL',
        description="Shadow map size in texels per side (a cube face, a spot map, one sun "
                    "cascade). 0: the quality preset chooses")
    shadow_bias: bpy.props.FloatProperty(
        name="Bias", default=LightRecord.shadow_bias, min=0.0, soft_max=10.0,
        description="Scale of the automatic shadow bias (about one shadow-map texel, more "
                    "at grazing angles). Lower shows contact detail and risks acne, higher "
                    "detaches shadows from their casters")


_CLASSES = (LanternSceneSettings, LanternLightSettings)


def register():
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.lantern = bpy.props.PointerProperty(type=LanternSceneSettings)
    bpy.types.Light.lantern = bpy.props.PointerProperty(type=LanternLightSettings)


def unregister():
    del bpy.types.Light.lantern
    del bpy.types.Scene.lantern
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
