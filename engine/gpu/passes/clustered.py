"""The clustered light pass (GL 4.3 compute; Frame.lighting "clustered"): one
dispatch shades every pixel with the lights its cluster lists (passes/light_cull.py),
the light tree's groups included, and adds them once into the HDR target and the
lighting render passes (shaders/lights.comp). Then each light whose shadows have a
map this frame is one more dispatch over its screen rectangle with that map (each map
is a texture of its own, so one light a dispatch), adding the same way; where the
screen passes are raster (Frame.compute False: a software rasteriser), the light pass
draws those lights as their volumes instead (passes/lights.py LightPass.drawn).

Every light is shaded by the functions the light volumes use (shaders/lights.glsl,
gbuffer_surface.glsl), so at error 0 (RenderSettings.light_error) the two forms give
the same image, up to the order of float additions.

reads: g_base, g_normal, g_mat, g_emit, g_depth, hdr, view, clusters, shadow_maps,
       g_smooth, g_sheen and ao (optional: as the light volumes read them)
writes: hdr
render passes: adds to DiffDir, GlossDir, Shadow (passes/ambient.py LIGHTING_AOVS)"""
from __future__ import annotations

import numpy as np

from ....core.lights import POINT, SUN
from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from .ambient import GBUFFER, LIGHTING_AOVS, LIGHTING_TARGETS, bind_gbuffer, surface_defines, \
    lighting_aovs
from .light_cull import TILE, set_tree_uniforms
from .lights import kind_defines, screen_rect, volume_hull
from .area_visibility import DEFINE as AREA_VISIBILITY, area_visibility, filtered
from .shadows import set_shadow_uniforms

GL_RGBA32F = 0x8814
# Images the shader writes, by binding: shaders/lights.comp.
IMAGES = ("hdr", "aov_diffuse", "aov_glossy", "aov_shadow")


class ClusteredLightPass(Pass):
    name = "lights"
    reads = GBUFFER + ("hdr", "view", "clusters")
    optional = ("shadow_maps", "g_smooth", "g_sheen", "ao", "field")
    writes = ("hdr",)
    aovs = LIGHTING_AOVS

    def __init__(self, ctx, pool, programs, table, environment, cull, contact):
        self.ctx, self.pool, self.programs, self.table = ctx, pool, programs, table
        self.environment, self.cull = environment, cull
        self.contact = contact          # shadows.ContactRays

    def aov_targets(self, frame):
        return LIGHTING_TARGETS if lighting_aovs(frame) else ()

    def needed(self, frame):
        return frame.lighting == "clustered" and bool(frame.scene.lights)

    def execute(self, frame, board):
        ctx, view, clusters = self.ctx, board["view"], board["clusters"]
        aovs = lighting_aovs(frame)
        self._bind_targets(board, aovs)
        self.table.texture.use(UNITS["u_lights"])
        self.environment.bind_tables()
        self.environment.bind_sheen(frame.scene.materials.values())
        tree, tree_texture = self.table.tree_for(frame.scene, clusters.error)
        self.cull.bind(tree_texture, clusters.counts)
        defines = (["WRITE_AOVS"] if aovs else []) + surface_defines(frame, board)
        w, h = frame.size

        if clusters.exact or tree is not None:
            listed = [frame.scene.lights[p] for p in clusters.exact]
            kinds = {light.kind for light in listed} | ({POINT} if tree is not None else set())
            prog = self._program(board, view, defines + kind_defines(kinds)
                                 + (["HAS_EXACT"] if listed else [])
                                 + (["HAS_TREE"] if tree is not None else []))
            set_uniform(prog, "cluster_tiles", clusters.tiles)
            set_tree_uniforms(prog, tree, clusters.error)
            set_uniform(prog, "n_exact", len(clusters.exact))
            set_uniform(prog, "u_offset", (0, 0))
            prog.run(*clusters.tiles)
            ctx.memory_barrier()
            frame.count("lights_drawn", len(frame.scene.lights) - len(clusters.mapped))

        shadow_maps = board.get("shadow_maps", {})
        for path in clusters.mapped if frame.compute else ():  # else the light volumes'
            light = frame.scene.lights[path]
            rect = (0, 0, w, h)
            if light.kind != SUN:
                centre = np.asarray(light.position, np.float64) - view.origin
                rect = screen_rect(view, frame.size,
                                   volume_hull(light, self.table.ranges[path], centre))
                rect = rect or (0, 0, w, h)
            if rect[2] <= 0 or rect[3] <= 0:
                continue
            visibility = None
            if filtered(light):
                visibility = area_visibility(ctx, self.pool, self.programs, frame, board, view,
                                             shadow_maps[path], self.table.index[path])
                self._bind_targets(board, aovs)     # its screen passes used the units
            prog = self._program(board, view, defines + kind_defines([light.kind])
                                 + ["SINGLE_LIGHT", "HAS_SHADOW"]
                                 + self.contact.defines(frame, board, light)
                                 + ([AREA_VISIBILITY] if visibility is not None else []))
            set_shadow_uniforms(prog, shadow_maps[path], frame.preset, view.origin)
            set_uniform(prog, "light_index", self.table.index[path])
            set_uniform(prog, "light_error", float(clusters.error))  # emitter groups'
            set_uniform(prog, "u_offset", rect[:2])
            prog.run(-(-rect[2] // TILE), -(-rect[3] // TILE))
            ctx.memory_barrier()
            if visibility is not None:
                self.pool.release(visibility)
            frame.count("lights_drawn")

    @staticmethod
    def _bind_targets(board, aovs):
        for unit, name in enumerate(IMAGES if aovs else IMAGES[:1]):
            board[name].bind_to_image(unit, read=True, write=True, format=GL_RGBA32F)

    def _program(self, board, view, defines):
        prog = self.programs.get("lights.comp", defines=defines, compute=True)
        bind_gbuffer(board, prog, view)
        return prog
