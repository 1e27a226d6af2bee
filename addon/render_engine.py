"""The LANTERN RenderEngine: F12, material previews and the viewport.

Kept thin: the engine runs in its own process (addon/host.py, engine/host/); F12 and
previews go through scene_render.py, the viewport through viewport.py. Only
`_paint` touches Blender's `gpu` module (absent in background mode), in Blender's
documented pattern: a float GPUTexture drawn inside bind_display_space_shader.
"""
import bpy

from ..core.passes import COMBINED, PASSES
from . import host as host_module
from .scene_render import blender_name, render_frame, requested_passes
from .viewport import ViewportRender, region_border, view_request

REDRAW_SECONDS = 1 / 60     # how often a viewport waiting for a frame looks for it
_timers = set()             # the redraw timers running, stopped with the add-on


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
        self._texture = None            # (frame number, GPUTexture) drawn last
        self._polling = False

    def __del__(self):
        viewport = getattr(self, "_viewport", None)
        if viewport is not None:
            viewport.close()

    # F12 and previews ---------------------------------------------------------------------
    def render(self, depsgraph):
        render_frame(self, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, COMBINED, 4, "RGBA", 'COLOR')
        for name in requested_passes(renderlayer):
            p = PASSES[name]
            self.register_pass(scene, renderlayer, blender_name(name), p.channels, p.chan_id,
                               p.kind)

    # Viewport ----------------------------------------------------------------------------
    def view_update(self, context, depsgraph):
        if self._viewport is None:
            self._viewport = ViewportRender()
        self._viewport.update(depsgraph)
        self._start_polling()

    def view_draw(self, context, depsgraph):
        if self._viewport is None:
            self.view_update(context, depsgraph)
        scene, region = depsgraph.scene, context.region
        view = view_request((region.width, region.height), context.region_data.view_matrix,
                            context.region_data.window_matrix,
                            scene.lantern.viewport_resolution, region_border(context, depsgraph))
        self._viewport.draw(depsgraph, view, lambda *frame: _paint(self, scene, *frame),
                            scene.lantern.preset, scene.render.film_transparent)
        if scene.lantern.viewport_stats and self._viewport.shown is not None:
            from .viewport_stats import draw_stats
            draw_stats(self._viewport.shown, region.height, context.preferences.system.ui_scale)
        self.update_stats("", self._viewport.status)
        while self._viewport.notices:
            self.report({'ERROR'}, self._viewport.notices.pop(0))
        self._start_polling()

    def _start_polling(self):
        if not self._polling and self._viewport is not None and self._viewport.waiting():
            self._polling = True
            poll = self._poll
            _timers.add(poll)
            bpy.app.timers.register(poll, first_interval=REDRAW_SECONDS)

    def _poll(self):
        """Tags a redraw when a new frame arrived; stops once nothing is to come."""
        try:
            viewport = self._viewport
            if host_module.get().take_fresh(viewport.name):
                self.tag_redraw()
            if viewport.waiting():
                return REDRAW_SECONDS
            self.tag_redraw()               # the last frame, or an error, to show
        except ReferenceError:              # the engine was freed with its viewport
            return None
        self._polling = False
        _timers.discard(self._poll)
        return None


def _paint(engine, scene, number, pixels, rect):
    """Blender's documented pattern: the frame as a float GPUTexture (made again only
    for a new frame, from the shared pixels with one copy), drawn over `rect` in the
    display-space shader."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    if engine._texture is None or engine._texture[0] != number:
        height, width = pixels.shape[:2]
        buffer = gpu.types.Buffer('FLOAT', width * height * 4, pixels.reshape(-1))
        engine._texture = (number, gpu.types.GPUTexture((width, height), format='RGBA16F',
                                                        data=buffer))
    x, y, w, h = rect
    gpu.state.blend_set('ALPHA_PREMULT')
    engine.bind_display_space_shader(scene)
    draw_texture_2d(engine._texture[1], (x, y), w, h)
    engine.unbind_display_space_shader()
    gpu.state.blend_set('NONE')


def register():
    bpy.utils.register_class(LanternRenderEngine)


def unregister():
    for poll in list(_timers):
        if bpy.app.timers.is_registered(poll):
            bpy.app.timers.unregister(poll)
    _timers.clear()
    bpy.utils.unregister_class(LanternRenderEngine)
