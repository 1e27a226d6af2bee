"""Panels: Lantern's own settings, and Blender's panels that apply to Lantern too.

As in Blender's Hydra add-ons, built-in panels opt in through COMPAT_ENGINES rather
than being copied.
"""
import bpy

ENGINE = "LANTERN"

# Built-in panels whose settings Lantern honours (dimensions, output, lights, camera,
# materials through the node tree, world colour).
_COMPATIBLE_PANELS = (
    "RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_output", "RENDER_PT_color_management",
    "DATA_PT_context_light", "DATA_PT_light", "DATA_PT_EEVEE_light",
    "DATA_PT_camera", "DATA_PT_camera_display", "DATA_PT_lens", "DATA_PT_context_camera",
    "DATA_PT_context_mesh", "DATA_PT_normals", "DATA_PT_uv_texture", "DATA_PT_shape_keys",
    "DATA_PT_vertex_groups", "DATA_PT_customdata",
    "MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "EEVEE_MATERIAL_PT_settings",
    "EEVEE_WORLD_PT_surface", "WORLD_PT_context_world",
)


class RENDER_PT_lantern(bpy.types.Panel):
    bl_idname = "RENDER_PT_lantern"
    bl_label = "Lantern"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(context.scene.lantern, "preset")


def _compatible_panels():
    for name in _COMPATIBLE_PANELS:
        panel = getattr(bpy.types, name, None)
        if panel is not None and hasattr(panel, "COMPAT_ENGINES"):
            yield panel


def register():
    bpy.utils.register_class(RENDER_PT_lantern)
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.add(ENGINE)


def unregister():
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.discard(ENGINE)
    bpy.utils.unregister_class(RENDER_PT_lantern)
