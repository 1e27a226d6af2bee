"""The LANTERN RenderEngine: F12, material previews and the viewport.

Kept thin: the exporter turns the evaluated depsgraph into an in-memory USD stage,
the engine renders that stage on its own GL thread, and the pixels come back here
(scene_render.py holds every step but the `gpu` drawing). Blender's own GL context is
never touched by ModernGL.
"""
import bpy

from .scene_render import ViewportSession, render_frame


class LanternRenderEngine(bpy.types.RenderEngine):
    bl_idname = "LANTERN"
    bl_label = "Lantern"
    bl_use_preview = True               # material, light and world previews
    bl_use_postprocess = True           # compositing and sequencer apply
    bl_use_shading_nodes_custom = False  # Blender's shader nodes (Principled BSDF) stay
    bl_use_eevee_viewport = True        # Material Preview shading stays EEVEE's, as with Cycles

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._viewport = None

    # F12 and previews ---------------------------------------------------------------------
    def render(self, depsgraph):
        render_frame(self, depsgraph)

    # Viewport ----------------------------------------------------------------------------
    def view_update(self, context, depsgraph):
        if self._viewport is None:
            self._viewport = ViewportSession()
        self._viewport.sync(depsgraph)

    def view_draw(self, context, depsgraph):
        if self._viewport is None:
            self.view_update(context, depsgraph)
        region, view = context.region, context.region_data
        try:
            rgba = self._viewport.draw_pixels(
                view.view_matrix, view.window_matrix, region.width, region.height)
        except Exception as error:
            self.report({'ERROR'}, f"Lantern: {error}")
            return
        _draw_pixels(self, depsgraph.scene, rgba)


def _draw_pixels(engine, scene, rgba):
    """Blender's documented pattern: a float GPUTexture drawn in the display-space shader."""
    import gpu
    from gpu_extras.batch import batch_for_shader

    height, width = rgba.shape[:2]
    buffer = gpu.types.Buffer('FLOAT', width * height * 4, rgba[::-1].ravel().tolist())
    texture = gpu.types.GPUTexture((width, height), format='RGBA16F', data=buffer)
    shader = gpu.shader.from_builtin('IMAGE')
    batch = batch_for_shader(shader, 'TRI_FAN', {
        "pos": ((0, 0), (width, 0), (width, height), (0, height)),
        "texCoord": ((0, 0), (1, 0), (1, 1), (0, 1)),
    })
    gpu.state.blend_set('ALPHA_PREMULT')
    engine.bind_display_space_shader(scene)
    shader.uniform_sampler("image", texture)
    batch.draw(shader)
    engine.unbind_display_space_shader()
    gpu.state.blend_set('NONE')


def register():
    bpy.utils.register_class(LanternRenderEngine)


def unregister():
    bpy.utils.unregister_class(LanternRenderEngine)
