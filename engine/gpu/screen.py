"""Screen passes in either form, from one GLSL body (docs/design.md, "Compute").

A pass that shades each pixel of its targets from textures (post, the supersample
reduction, the render passes, the resolve, ambient occlusion, the dome) is written
once, as `screen_pixel` in its shaders/<body>.glsl, and runs as
  raster    one full-screen triangle (shaders/screen.frag, GL 3.3), its outputs the
            framebuffer's attachments: fragment work, which a datacenter GPU runs on
            a few of its cores (4 of an H100's 132 SMs);
  compute   a dispatch of 8 x 8 invocations over the targets (shaders/screen.comp,
            GL 4.3), its outputs images at the same numbers: every core runs it;
by the frame's form (Frame.compute, RenderSettings.compute). A body that needs to
know its stage has COMPUTE defined in the compute form (programs.py)."""
from __future__ import annotations

GROUP = 8                   # shaders/screen.comp local size


def screen_program(programs, body: str, defines=(), compute: bool = False, outputs: int = 1):
    """The program running shaders/<body>.glsl's screen_pixel in the form asked for,
    writing `outputs` targets."""
    generated = (("screen_body.glsl", f'#include "{body}.glsl"\n'),)
    defines = list(defines) + [f"SCREEN_OUTPUTS {outputs}"]
    if compute:
        return programs.get("screen.comp", defines=defines, compute=True, generated=generated)
    return programs.get("fullscreen.vert", "screen.frag", defines, generated=generated)


def run_screen(ctx, programs, pool, prog, targets, compute: bool):
    """Runs a screen_program over `targets` (textures of one size, in output order)."""
    if compute:
        for unit, texture in enumerate(targets):
            texture.bind_to_image(unit, read=False, write=True)
        w, h = targets[0].size
        prog.run(-(-w // GROUP), -(-h // GROUP))
        # Whatever reads the targets next (a sampler, a framebuffer read, an image)
        # must see these writes: image stores are not ordered with them by GL.
        ctx.memory_barrier()
        return
    pool.framebuffer(list(targets)).use()
    programs.fullscreen(prog)
