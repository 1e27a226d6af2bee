"""Panels: Lantern's own settings, and Blender's panels that apply to Lantern too.

Blender's panels opt in through COMPAT_ENGINES, as Cycles and Hydra Storm do. The
panels built for Blender's own engines are taken, minus the ones whose settings Lantern
does not honour. Excluding (rather than listing what to keep) follows the panel list as
it changes between Blender versions: a new general panel appears, and only an
engine-specific one that slips through needs a line here.
"""
from fnmatch import fnmatchcase

import bpy

ENGINE = "LANTERN"

# Panels of these engines are candidates ('BLENDER_EEVEE_NEXT' is EEVEE in 4.2-4.4).
_SOURCE_ENGINES = {"BLENDER_RENDER", "BLENDER_EEVEE", "BLENDER_EEVEE_NEXT", "CYCLES"}

# ... minus the ones Lantern does not honour (fnmatch patterns on the class name).
_EXCLUDED = (
    # Cycles' and EEVEE's own render settings: sampling, light paths, ray tracing, film
    # filters, motion blur, hair, volumes, bake, performance, light probes, passes.
    "CYCLES_*", "NODE_CYCLES_*", "RENDER_PT_eevee_*", "SCENE_PT_eevee_*", "VIEWLAYER_PT_eevee_*",
    "*_PT_*lightprobe*", "VIEWLAYER_PT_layer_passes*", "VIEWLAYER_PT_filter",
    "VIEW3D_PT_shading_render_pass",
    # EEVEE's per-light shadow settings (jitter, filter, resolution limit) and custom
    # cut-off distance; Lantern's Shadow panel below holds Cast Shadow and its own settings.
    "DATA_PT_EEVEE_light_shadow", "DATA_PT_EEVEE_light_distance",
    # The type-only light panel of the Workbench-era engine; EEVEE's light panel (type,
    # colour, power, radius, shape) is the one Lantern uses, with its Beam Shape child.
    "DATA_PT_light", "NODE_DATA_PT_light",
    # Material and world features Lantern does not render.
    "EEVEE_MATERIAL_PT_volume", "EEVEE_MATERIAL_PT_settings_volume",
    "NODE_EEVEE_MATERIAL_PT_settings_volume", "EEVEE_MATERIAL_PT_displacement",
    "EEVEE_MATERIAL_PT_thickness", "EEVEE_WORLD_PT_volume", "EEVEE_WORLD_PT_mist",
    "EEVEE_WORLD_PT_settings", "EEVEE_WORLD_PT_sun*",
    # Depth of field, stereoscopy and multi-view, light linking, shadow terminator.
    "DATA_PT_camera_dof*", "DATA_PT_camera_stereoscopy", "RENDER_PT_stereoscopy",
    "RENDER_PT_output_views", "OBJECT_PT_shading", "OBJECT_PT_shadow_terminator",
    # Per-view-layer material/world overrides, Freestyle lines and Grease Pencil
    # rendering: the exporter does not apply them.
    "VIEWLAYER_PT_override", "*freestyle*", "RENDER_PT_gpencil", "RENDER_PT_grease_pencil*",
    "RENDER_PT_simplify_greasepencil",
)

_adopted = []  # the built-in panels this add-on added LANTERN to, to undo exactly those


def adoptable_panels():
    """Blender's panels that apply to Lantern, by class name order."""
    for name in sorted(dir(bpy.types)):
        cls = getattr(bpy.types, name, None)
        if not (isinstance(cls, type) and issubclass(cls, bpy.types.Panel)):
            continue
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if not isinstance(engines, set) or not engines & _SOURCE_ENGINES:
            continue
        if any(fnmatchcase(cls.__name__, pattern) for pattern in _EXCLUDED):
            continue
        yield cls


class LanternPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class LANTERN_RENDER_PT_quality(LanternPanel, bpy.types.Panel):
    bl_label = "Quality"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(context.scene.lantern, "preset")
        layout.prop(context.scene.lantern, "viewport_resolution")
        layout.prop(context.scene.lantern, "subdivision")
        layout.prop(context.scene.lantern, "viewport_stats")


class LANTERN_RENDER_PT_film(LanternPanel, bpy.types.Panel):
    bl_label = "Film"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(context.scene.render, "film_transparent", text="Transparent")


class LANTERN_VIEWLAYER_PT_passes(LanternPanel, bpy.types.Panel):
    """The render passes the engine computes (core/passes.py), by Blender's own view
    layer switches: they come out of F12 as Blender's passes of the same names."""
    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context):
        from ..core.passes import switches
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column(heading="Include", align=True)
        col.prop(context.view_layer, "use_pass_combined")
        for prop, label in switches():
            col.prop(context.view_layer, prop, text=label)


class LANTERN_LIGHT_PT_shadow(LanternPanel, bpy.types.Panel):
    """Cast Shadow and Lantern's shadow-map settings, under EEVEE's light panel (whose
    Radius / Angle sets how soft the shadow is)."""
    bl_label = "Shadow"
    bl_context = "data"
    bl_parent_id = "DATA_PT_EEVEE_light"

    @classmethod
    def poll(cls, context):
        return context.light is not None and super().poll(context)

    def draw_header(self, context):
        self.layout.prop(context.light, "use_shadow", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        light = context.light
        layout.active = light.use_shadow
        col = layout.column()
        col.prop(light.lantern, "shadow_resolution")
        col.prop(light.lantern, "shadow_bias")


_CLASSES = (LANTERN_RENDER_PT_quality, LANTERN_RENDER_PT_film, LANTERN_VIEWLAYER_PT_passes,
            LANTERN_LIGHT_PT_shadow)


def register():
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    for panel in adoptable_panels():
        if ENGINE not in panel.COMPAT_ENGINES:
            panel.COMPAT_ENGINES.add(ENGINE)
            _adopted.append(panel)


def unregister():
    for panel in _adopted:
        panel.COMPAT_ENGINES.discard(ENGINE)
    _adopted.clear()
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
