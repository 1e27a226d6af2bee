"""The resolve pass: the HDR accumulation into the output image (shaders/resolve.glsl,
a screen pass in either form: engine/gpu/screen.py), read back in one copy
(engine/gpu/readback.py): in the caller's row order and format, into the caller's
buffer, or queued behind a fence. Alpha is 1, or coverage when the render is
transparent (the HDR target's alpha: 1 where a surface was drawn, filtered by
anti-aliasing).

Nothing masks a non-finite value: the GPU counts the pixels holding NaN or Inf
(`stats["nonfinite_pixels"]`; the compute form as it writes them, the raster form in
engine/gpu/readback.py after) and, only when there are some, the pass draws the
scene's object ids (shaders/ids.vert, points.frag's POINTS_ID) to name the prims those
pixels lie on, in one warning per render ("the background" where nothing is).

reads: hdr, view   writes: output or output_half (the read-back's format), rgba (the
image, numpy; None while queued)"""
from __future__ import annotations

import time

import numpy as np

from ..framegraph import Pass
from ..points import set_camera_facing
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program

# The target the image is resolved into, by read-back format (engine/gpu/readback.py).
OUTPUT = {"float32": "output", "half": "output_half"}
NAMED = 5                    # prims named in the warning, most pixels first


class ResolvePass(Pass):
    name = "resolve"
    reads = ("hdr", "view")
    writes = ("rgba",)
    writes_optional = ("output", "output_half")

    def __init__(self, ctx, pool, programs, geometry, depth, readback):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.geometry, self.depth, self.readback = geometry, depth, readback
        self.warnings = []       # the last finished render's

    def wanted(self, frame):
        return (OUTPUT[frame.readback.format],)

    def execute(self, frame, board):
        (w, h), request = frame.size, frame.readback
        output = board[OUTPUT[request.format]]
        self.ctx.disable(self.ctx.BLEND | self.ctx.DEPTH_TEST | self.ctx.CULL_FACE)
        prog = screen_program(self.programs, "resolve", (), frame.compute)
        board["hdr"].use(UNITS["hdr"])
        set_uniform(prog, "transparent", bool(frame.transparent))
        set_uniform(prog, "top_down", bool(request.top_down))
        slot = self.readback.slot()
        fbo = self.pool.framebuffer([output])
        if frame.compute:            # the compute form counts as it writes
            self.readback.counting(slot)
            run_screen(self.ctx, self.programs, self.pool, prog, [output], True)
        else:
            run_screen(self.ctx, self.programs, self.pool, prog, [output], False)
            self.readback.count(slot, board["hdr"], fbo, (w, h), frame.transparent)
        t0 = time.perf_counter()
        board["rgba"] = self.readback.read(slot, fbo, (w, h), request)
        frame.timings["readback"] = time.perf_counter() - t0
        frame.slot = slot

    def finish(self, frame, view, rgba):
        """The frame's non-finite count and warning, once its pixels are in host
        memory. The object ids are drawn with the session's geometry as it is now:
        the frame's own when it was not queued."""
        count = self.readback.nonfinite(frame.slot)
        frame.stats["nonfinite_pixels"] = count
        self.warnings = []
        if count:
            bad = ~np.isfinite(rgba).all(axis=-1)
            if not frame.readback.top_down:
                bad = bad[::-1]
            self.warnings.append(self._name(frame, view, bad, count))

    def _name(self, frame, view, bad, count) -> str:
        """The warning: how many pixels, on which prims."""
        ids = self._object_ids(frame, view)[bad]
        names = {}
        for oid, n in zip(*np.unique(ids, return_counts=True)):
            path = "the background" if oid == 0 else \
                (self.geometry.path_of(int(oid) - 1) or f"object {int(oid) - 1}")
            names[path] = names.get(path, 0) + int(n)
        ranked = sorted(names.items(), key=lambda kv: -kv[1])
        listed = ", ".join(f"{p} ({n} px)" for p, n in ranked[:NAMED])
        more = f" and {len(ranked) - NAMED} more" if len(ranked) > NAMED else ""
        return (f"{count} pixels of the image are not finite (NaN or Inf): on "
                f"{listed}{more}")

    def _object_ids(self, frame, view) -> np.ndarray:
        """(H, W) int: 1 + the object id nearest the camera at each pixel, 0 where
        nothing is drawn, row 0 = top. Drawn only when needed."""
        ctx, (w, h) = self.ctx, frame.size
        ids = ctx.texture((w, h), 1, dtype="i4")
        depth = self.pool.acquire((w, h), "depth")
        fbo = ctx.framebuffer([ids], depth)
        try:
            fbo.use()
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)
            ctx.enable(ctx.DEPTH_TEST)
            ctx.depth_func = ">"
            ctx.disable(ctx.CULL_FACE | ctx.BLEND)
            self.depth.far_clip(True)
            prog = self.programs.get("ids.vert", "ids.frag",
                                     self.geometry.commands.object_defines())
            self.geometry.bind_objects(UNITS["u_objects"])
            set_uniform(prog, "view_proj", view.view_proj)
            set_uniform(prog, "u_far", view.far_clip)
            view.set_origin(prog)
            self.geometry.commands.draw_casters(prog)
            self.geometry.points.draw(self.programs, "id",
                                      lambda p, cloud: set_camera_facing(p, view))
            out = np.frombuffer(ids.read(), np.int32).reshape(h, w)[::-1].copy()
        finally:
            self.depth.far_clip(False)
            ctx.disable(ctx.DEPTH_TEST)
            fbo.release()
            ids.release()
            self.pool.release(depth)
        return out
