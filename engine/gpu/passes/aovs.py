"""The surface render-pass pass: Depth, Normal and Emit as float32 images, read from
the G-buffer, for the render passes a frame asks for (core/passes.py). A frame that
asks for none does not run it. Each asked-for pass is one screen pass (shaders/
aovs.glsl, in either form: engine/gpu/screen.py) of a one-output variant into its own
target.

reads: g_depth, g_normal, g_emit, view
render passes: Depth (aov_depth, R32F), Normal (aov_normal), Emit (aov_emit)"""
from __future__ import annotations

from ....core.passes import BACKGROUND_DEPTH
from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program

VARIANT = {"Depth": "AOV_DEPTH", "Normal": "AOV_NORMAL", "Emit": "AOV_EMIT"}


class AovPass(Pass):
    name = "aovs"
    reads = ("g_depth", "g_normal", "g_emit", "view")
    aovs = {"Depth": ("aov_depth", 0), "Normal": ("aov_normal", 0), "Emit": ("aov_emit", 0)}

    def __init__(self, ctx, pool, programs):
        self.ctx, self.pool, self.programs = ctx, pool, programs

    def needed(self, frame):
        return any(name in frame.aovs for name in self.aovs)

    def execute(self, frame, board):
        ctx, view = self.ctx, board["view"]
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        for name in ("g_depth", "g_normal", "g_emit"):
            board[name].use(UNITS[name])
        for aov, (target, _) in self.aovs.items():
            if aov not in frame.aovs:
                continue
            prog = screen_program(self.programs, "aovs", [VARIANT[aov]], frame.compute)
            view.set_camera(prog)
            set_uniform(prog, "background_depth", BACKGROUND_DEPTH)
            run_screen(ctx, self.programs, self.pool, prog, [board[target]], frame.compute)
