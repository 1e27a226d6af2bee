"""The near field of the diffuse bounce: the light between surfaces closer than the
irradiance field's probes are apart (a block beside a wall, a box's corners), which the
field (passes/irradiance.py) holds too coarsely or lets leak. The AO pass's horizon
search (shaders/ao.glsl, its NEAR_FIELD variant: a visibility bit mask, Therrien et al.
2023, "Screen Space Indirect Lighting with Visibility Bitmask"), run within half a probe
spacing over the lit frame, marks the sectors of each pixel's hemisphere that nearby
surfaces hide and gathers their lit colour; then each pixel's diffuse light takes that
in place of the field's over the same sectors (shaders/near_field.glsl):

    diffuse = albedo x (field's irradiance x open share + gathered irradiance)

so no light is counted twice, and a pixel nothing nearby hides is left as it was.

A still (RenderSettings.gathers(): F12, the command line, a sequence's frame) gathers
instead from the scene's triangles, over the whole hemisphere: the final gather
(shaders/gather_trace.comp, one ray an invocation, each shaded at its hit as the field's
probes shade theirs, with the field of one bounce fewer; gather_mean.glsl's mean per
block), whose share is 1, so its pixels take the gathered light in place of the field's.
It sees what the probes are too coarse for and the screen does not show (the floor under
a table); a viewport's frames keep the screen's search, which costs a frame far less.

The lit colour is the current frame's, after the ambient and light passes (the direct
light, emission, and the field's bounce at the surfaces seen): a still, a sequence's
frame and the viewport's each gather from themselves, with no history to reproject or
converge. This is why the search runs here, after the lights, and not within the AO
pass before the ambient pass: no frame holds its direct light before the light passes
(the previous frame's copy would leave a still, F12 and every frame of `lantern
compare` without it). The gathered surfaces carry their own field bounce but not their
near field (one near bounce).

Only in a frame with the field (a diffuse bounce, GL 4.3); a dispatch in either form of
the frame (as the glossy bounce's), so both forms give the same image. The change goes
to DiffInd too (the bounce's render pass), so the render passes still add up to the image. Before the glossy
bounce, whose copy of the lit frame then shows it.

reads: g_base, g_normal, g_mat, g_emit, g_depth, hdr, view; field, g_smooth and g_sheen
       (optional)   writes: hdr
render passes: DiffInd (added to in place)"""
from __future__ import annotations

import numpy as np

from ..framegraph import Pass
from ..lit_copy import LitCopy
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program
from .ambient import GBUFFER, LIGHTING_AOVS, bind_gbuffer, surface_defines
from .ao import search_setup

# The search's reach, in probe spacings: what lies further the field resolves. Against
# the Cycles references at medium (HDR-FLIP; the field alone 0.0941 / 0.3344 / 0.1963):
# half a spacing gave the closed box 0.0919, the sunlit room 0.3280, the emissive panel
# 0.1943; one spacing 0.0934 / 0.3203 / 0.1967; two 0.1029 / 0.3056 / 0.2258 (the
# screen's nearest surfaces stand for ever more of the hemisphere they cannot see).
REACH = 0.5
# The final gather (a still's): rays a block, and at most this many a frame (blocks grow
# past the preset's near_block where the image holds more). Against the Cycles
# references at medium (docs/rendering.md "Final gather").
GATHER_RAYS = {"low": 16, "medium": 32, "high": 64, "ultra": 128}
GATHER_BUDGET = {"low": 65536, "medium": 131072, "high": 262144, "ultra": 524288}
GATHER_GROUP = 64                 # shaders/gather_trace.comp's local size


class NearFieldPass(Pass):
    name = "near_field"
    reads = GBUFFER + ("hdr", "view")
    # A viewport's field may have no complete update yet: a frame without it (lit
    # directly meanwhile) has no near field either.
    optional = ("ao", "g_smooth", "g_sheen", "field")
    writes = ("hdr",)
    aovs = {"DiffInd": LIGHTING_AOVS["DiffInd"]}    # added to in place

    def __init__(self, ctx, pool, programs, field_pass, proc):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.field_pass = field_pass       # passes/irradiance.py: whether a field is made
        self.lit = LitCopy(ctx, pool, programs, proc, compute=True)   # the field's GL 4.3

    def needed(self, frame) -> bool:
        return frame.preset.ao_slices > 0 and self.field_pass.needed(frame)

    def execute(self, frame, board):
        if "field" not in board:
            return
        ctx, view, field = self.ctx, board["view"], board["field"]
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        lit = self.lit.copy(board["hdr"])
        lit.use(UNITS["hdr"])
        board["g_depth"].use(UNITS["g_depth"])
        board["g_normal"].use(UNITS["g_normal"])
        hits = self.field_pass.gather_tables() if frame.options.gathers() else None
        if hits is not None:
            step, raw = self._gather(frame, view, hits)
        else:
            search = screen_program(self.programs, "ao", ["NEAR_FIELD"], compute=True)
            step, raw = search_setup(self.pool, search, frame, view,
                                     REACH * min(float(np.min(g.step)) for g in field.grids),
                                     frame.preset.near_block, frame.preset.near_steps)
            set_uniform(search, "u_lit", UNITS["hdr"])
            run_screen(ctx, self.programs, self.pool, search, [raw], True)
        defines = ["IRRADIANCE_FIELD"] + surface_defines(frame, board)
        targets = [board["hdr"]]
        if "DiffInd" in frame.aovs:     # it takes the change, read and stored in place
            defines.append("WRITE_AOVS")
            targets.append(board["aov_diffuse_indirect"])
        prog = screen_program(self.programs, "near_field", defines, compute=True,
                              outputs=len(targets))
        bind_gbuffer(board, prog, view)
        field.bind(prog)
        set_uniform(prog, "field_eye", view.origin)
        raw.use(UNITS["post_src"])
        set_uniform(prog, "u_near", UNITS["post_src"])
        set_uniform(prog, "u_step", step)
        set_uniform(prog, "u_lit", UNITS["hdr"])
        if len(targets) > 1:
            board["aov_diffuse_indirect"].use(UNITS["visibility_tex"])
            set_uniform(prog, "u_diffuse", UNITS["visibility_tex"])
        run_screen(ctx, self.programs, self.pool, prog, targets, True)
        self.pool.release(raw)

    def _gather(self, frame, view, hits):
        """The final gather (shaders/gather_trace.comp, then gather_mean.glsl's mean per
        block) into a raw target at its block size: the preset's rays a block, blocks of
        near_block pixels a side or larger, so that a frame traces at most GATHER_BUDGET
        rays. Returns (block, raw)."""
        name = frame.preset.name
        rays = GATHER_RAYS.get(name, GATHER_RAYS["medium"])
        budget = GATHER_BUDGET.get(name, GATHER_BUDGET["medium"])
        w, h = frame.size
        step = max(int(frame.supersample), 1) * max(int(frame.preset.near_block), 1)
        while -(-w // step) * -(-h // step) * rays > budget:
            step += 1
        blocks = (-(-w // step), -(-h // step))
        trace = self.programs.get("gather_trace.comp", None, hits.defines(), compute=True)
        self.field_pass.bind_hits(trace, frame)
        # Positions camera-relative (not view.set_camera's origin: the light table's
        # positions stay in world space, as the field's probes read them).
        set_uniform(trace, "inv_view_proj", view.inv_view_proj)
        set_uniform(trace, "cam_forward", view.camera.forward)
        set_uniform(trace, "cam_ortho", bool(view.camera.ortho))
        set_uniform(trace, "field_eye", view.origin)
        set_uniform(trace, "u_step", step)
        set_uniform(trace, "u_gather_rays", rays)
        set_uniform(trace, "u_blocks", blocks)
        traced = self.pool.acquire((blocks[0] * rays, blocks[1]), "rgba32f")
        traced.bind_to_image(0, read=False, write=True)
        trace.run(-(-blocks[0] * rays // GATHER_GROUP), blocks[1])
        self.ctx.memory_barrier()
        raw = self.pool.acquire(blocks, "rgba32f")
        mean = screen_program(self.programs, "gather_mean", [], compute=True)
        traced.use(UNITS["post_src"])
        set_uniform(mean, "u_gather_rays_tex", UNITS["post_src"])
        set_uniform(mean, "u_gather_rays", rays)
        run_screen(self.ctx, self.programs, self.pool, mean, [raw], True)
        self.pool.release(traced)
        frame.stats["gather_rays"] = blocks[0] * blocks[1] * rays
        return step, raw

    def release(self):
        self.lit.release()
