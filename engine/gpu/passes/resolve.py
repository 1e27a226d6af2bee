"""The resolve pass: the HDR accumulation into a float32 image, read back top row
first. Alpha is 1, or coverage when the render is transparent.

reads: hdr, g_depth   writes: output, rgba (the image, numpy)"""
from __future__ import annotations

import numpy as np

from ..framegraph import Pass
from ..programs import UNITS, set_uniform


class ResolvePass(Pass):
    name = "resolve"
    reads = ("hdr", "g_depth")
    writes = ("output", "rgba")

    def __init__(self, ctx, pool, programs):
        self.ctx, self.pool, self.programs = ctx, pool, programs

    def execute(self, frame, board):
        ctx, (w, h) = self.ctx, frame.size
        fbo = self.pool.framebuffer([board["output"]])
        fbo.use()
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        prog = self.programs.get("fullscreen.vert", "resolve.frag")
        board["hdr"].use(UNITS["hdr"])
        board["g_depth"].use(UNITS["g_depth"])
        set_uniform(prog, "transparent", bool(frame.transparent))
        self.programs.fullscreen(prog)
        data = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
        board["rgba"] = data.reshape(h, w, 4)[::-1].copy()  # GL rows run bottom-up
