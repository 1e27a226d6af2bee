"""The ambient pass: the light that is everywhere, once, full screen: the dome
(spherical-harmonics irradiance for diffuse, an analytic environment BRDF for
specular), emission (added here and only here), and the dome as the background.
It starts the HDR target.

reads: g_base, g_normal, g_mat, g_emit, g_depth, view   writes: hdr"""
from __future__ import annotations

import numpy as np

from ..framegraph import Pass
from ..programs import UNITS, set_uniform

GBUFFER = ("g_base", "g_normal", "g_mat", "g_emit", "g_depth")


def bind_gbuffer(board, prog, view):
    """The G-buffer and the camera, as every screen-space lighting pass reads them
    (positions from depth are camera-relative: lib.glsl)."""
    for name in GBUFFER:
        board[name].use(UNITS[name])
    view.set_camera(prog)


class AmbientPass(Pass):
    name = "ambient"
    reads = GBUFFER + ("view",)
    writes = ("hdr",)

    def __init__(self, ctx, pool, programs, textures):
        self.ctx, self.pool, self.programs, self.textures = ctx, pool, programs, textures
        self._vao = None

    def execute(self, frame, board):
        ctx = self.ctx
        fbo = self.pool.framebuffer([board["hdr"]])
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        dome = frame.scene.dome
        defines = ["HAS_DOME_MAP"] if dome is not None and dome.texture else []
        prog = self.programs.get("fullscreen.vert", "ambient.frag", defines)
        bind_gbuffer(board, prog, board["view"])
        set_uniform(prog, "has_dome", dome is not None)
        set_uniform(prog, "transparent", bool(frame.transparent))
        if dome is not None:
            set_uniform(prog, "dome_sh", np.asarray(dome.sh, "f4"))
            set_uniform(prog, "dome_radiance", dome.radiance)
            if dome.texture:
                self.textures.dome(dome.texture).use(UNITS["dome_map"])
                set_uniform(prog, "dome_to_local", dome.rotation.T)
        self.programs.fullscreen(prog)
        ctx.disable(ctx.BLEND)
