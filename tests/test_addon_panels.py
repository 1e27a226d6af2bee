"""Panels: Blender's own panels that apply to Lantern poll true with it (material slots,
node trees, light settings), engine-specific ones do not, and Lantern's panels show
the settings it honours."""
from types import SimpleNamespace

import pytest

SLOTS = "EEVEE_MATERIAL_PT_context_material"


@pytest.fixture
def addon():
    import lantern
    lantern.register()
    yield
    lantern.unregister()


class RecordingLayout:
    """Stands in for a UILayout: records the properties a panel draws; rows, columns,
    separators and the like are the layout itself."""

    def __init__(self):
        self.props = []

    def prop(self, data, name, **kw):
        self.props.append(name)

    def __getattr__(self, name):
        return lambda *args, **kw: self


def _drawn(panel, context, method="draw"):
    layout = RecordingLayout()
    getattr(panel, method)(SimpleNamespace(layout=layout, bl_space_type='PROPERTIES'), context)
    return layout.props


def _light_context(empty_scene, kind):
    import bpy
    light = bpy.data.lights.new(kind.title(), kind)
    ob = bpy.data.objects.new(kind.title(), light)
    empty_scene.collection.objects.link(ob)
    return SimpleNamespace(engine="LANTERN", light=light, object=ob, scene=empty_scene,
                           space_data=None)


def test_blenders_panels_that_apply_poll_true(addon, empty_scene):
    import bpy
    cube = bpy.data.objects.new("Cube", bpy.data.meshes.new("Cube"))
    material = bpy.data.materials.new("Mat")
    cube.data.materials.append(material)
    material_context = SimpleNamespace(engine="LANTERN", object=cube, material=material,
                                       world=None, scene=empty_scene)
    assert getattr(bpy.types, SLOTS).poll(material_context)      # the material slot list
    assert bpy.types.EEVEE_MATERIAL_PT_surface.poll(material_context)  # its node tree
    spot = _light_context(empty_scene, "SPOT")
    for name in ("DATA_PT_context_light", "DATA_PT_EEVEE_light", "DATA_PT_spot",
                 "DATA_PT_EEVEE_light_influence", "LANTERN_LIGHT_PT_shadow"):
        assert getattr(bpy.types, name).poll(spot), name
    # Without Lantern as the engine, the same panels stay out of the way.
    other = SimpleNamespace(**{**vars(spot), "engine": "SOMEONE_ELSE"})
    assert not bpy.types.LANTERN_LIGHT_PT_shadow.poll(other)
    assert not bpy.types.DATA_PT_spot.poll(other)


def test_cast_shadow_and_lanterns_shadow_settings_are_in_the_light_panel(addon, empty_scene):
    import bpy
    context = _light_context(empty_scene, "POINT")
    panel = bpy.types.LANTERN_LIGHT_PT_shadow
    assert panel.bl_parent_id == "DATA_PT_EEVEE_light"
    assert _drawn(panel, context, "draw_header") == ["use_shadow"]
    assert _drawn(panel, context) == ["shadow_resolution", "shadow_bias"]
    # The light's radius (soft size) is Blender's own, in the parent panel.
    assert "shadow_soft_size" in _drawn(bpy.types.DATA_PT_EEVEE_light, context)


def test_the_render_panels_show_only_what_the_engine_honours(addon, empty_scene):
    import bpy
    context = SimpleNamespace(engine="LANTERN", scene=empty_scene)
    assert _drawn(bpy.types.LANTERN_RENDER_PT_quality, context) == [
        "preset", "viewport_resolution", "subdivision", "viewport_stats"]
    assert _drawn(bpy.types.LANTERN_RENDER_PT_film, context) == ["film_transparent"]


def test_the_passes_panel_lists_the_passes_the_engine_computes(addon, empty_scene):
    """Blender's own view-layer switches, for the passes of core/passes.py that the
    engine provides (one table), and no other."""
    import bpy
    from lantern.core.passes import provided
    context = SimpleNamespace(engine="LANTERN", scene=empty_scene,
                              view_layer=empty_scene.view_layers[0])
    assert _drawn(bpy.types.LANTERN_VIEWLAYER_PT_passes, context) == \
        ["use_pass_combined"] + list(dict.fromkeys(p.view_layer for p in provided()))


def test_engine_specific_panels_stay_out(addon):
    import bpy
    from lantern.addon.panels import ENGINE
    for name in ("CYCLES_RENDER_PT_sampling", "CYCLES_LIGHT_PT_light", "RENDER_PT_eevee_sampling",
                 "DATA_PT_EEVEE_light_shadow", "DATA_PT_light", "EEVEE_MATERIAL_PT_volume",
                 "VIEWLAYER_PT_layer_passes", "DATA_PT_camera_dof"):
        assert ENGINE not in getattr(bpy.types, name).COMPAT_ENGINES, name
    for name in (SLOTS, "RENDER_PT_format", "RENDER_PT_color_management", "DATA_PT_lens",
                 "EEVEE_WORLD_PT_surface", "MATERIAL_PT_preview"):
        assert ENGINE in getattr(bpy.types, name).COMPAT_ENGINES, name


def test_shader_nodes_stay_usable(addon):
    """Lantern reads Blender's node trees: the node editor keeps Principled BSDF and
    friends (a custom-nodes engine would hide them), and Material Preview shading stays
    EEVEE's."""
    import bpy
    engine = next(c for c in bpy.types.RenderEngine.__subclasses__()
                  if getattr(c, "bl_idname", "") == "LANTERN")
    assert engine.bl_use_shading_nodes_custom is False
    assert engine.bl_use_eevee_viewport and engine.bl_use_preview


def test_unregister_gives_every_panel_back():
    import bpy
    import lantern

    def lantern_panels():
        return {name for name in dir(bpy.types)
                if "LANTERN" in (getattr(getattr(bpy.types, name), "COMPAT_ENGINES", None) or ())}

    before = lantern_panels()
    lantern.register()
    assert len(lantern_panels() - before) > 50
    lantern.unregister()
    assert lantern_panels() == before
