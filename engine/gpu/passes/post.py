"""The post chain (docs/design.md, Framebuffers and post-processing): full-screen
operations on the scene-linear image (shaders/post.glsl, a screen pass in either form:
engine/gpu/screen.py), each drawn from the current image into a fresh target of the same format that then becomes the image (ping-pong through the pool: two
targets alternate). In order, each only when asked for:

  fxaa       frames not supersampled whose preset asks for it (antialias.py),
             at geometric edges only (depth or normal changes around the pixel)
  exposure   x 2^stops (RenderSettings.exposure)
  blur       separable Gaussian, sigma in pixels (RenderSettings.blur): two draws
  grayscale  Rec. 709 luminance (RenderSettings.grayscale)
  mirror     flip x, y or both (RenderSettings.mirror: "x", "y", "xy")
Blender's view transforms and looks are not here: they turn the linear image into
display values when a file is written (engine/color.py, OpenColorIO with Blender's
config, byte-identical to Blender's own save; docs/rendering.md says why it stays on that
path). Inside Blender nothing here runs unless asked: the image stays scene linear and
Blender's colour management applies.

reads: hdr, g_depth, g_normal (FXAA), view   writes: hdr"""
from __future__ import annotations

from ..framegraph import TARGETS, Pass
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program

MIRRORS = ("", "x", "y", "xy")


def stages(frame) -> list:
    """[(variant, uniforms)] this frame draws, in order."""
    o = frame.options
    out = []
    if frame.supersample == 1 and frame.fxaa:
        out.append(("POST_FXAA", {}))
    if o.exposure != 0.0:
        out.append(("POST_SCALE", {"scale": 2.0 ** o.exposure, "alpha_scale": 1.0}))
    if o.blur > 0.0:
        out.append(("POST_BLUR", {"direction": (1.0, 0.0), "sigma": float(o.blur)}))
        out.append(("POST_BLUR", {"direction": (0.0, 1.0), "sigma": float(o.blur)}))
    if o.grayscale:
        out.append(("POST_GRAYSCALE", {}))
    if o.mirror:
        out.append(("POST_MIRROR", {"flip": ("x" in o.mirror, "y" in o.mirror)}))
    return out


class PostPass(Pass):
    name = "post"
    reads = ("hdr", "g_depth", "g_normal", "view")
    writes = ("hdr",)

    def __init__(self, ctx, pool, programs):
        self.ctx, self.pool, self.programs = ctx, pool, programs

    def needed(self, frame):
        return bool(stages(frame))

    def execute(self, frame, board):
        ctx = self.ctx
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        for variant, uniforms in stages(frame):
            source = board["hdr"]
            target = self.pool.acquire(frame.size, TARGETS["hdr"])
            prog = screen_program(self.programs, "post", [variant], frame.compute)
            source.use(UNITS["post_src"])
            if variant == "POST_FXAA":
                board["g_depth"].use(UNITS["g_depth"])
                board["g_normal"].use(UNITS["g_normal"])
                board["view"].set_camera(prog)
            for name, value in uniforms.items():
                set_uniform(prog, name, value)
            run_screen(ctx, self.programs, self.pool, prog, [target], frame.compute)
            board["hdr"] = target
            self.pool.release(source)
