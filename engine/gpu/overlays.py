"""The overlay pass: sprites, then text, blended over a display-referred image.

The image goes up premultiplied as float (so a pixel no quad covers comes back to the
same byte), quads blend premultiplied (ONE, ONE_MINUS_SRC_ALPHA), and the result is
read back and un-premultiplied. Glyph quads come laid out by engine/overlays.py."""
from __future__ import annotations

import numpy as np
import moderngl

from ..overlay_options import halo_width
from .programs import UNITS, set_uniform
from .resources import Uploads


def draw_overlays(gl, display8, sprites, runs, atlas):
    """display8 (H, W, 4) uint8 -> the same with `sprites` and the text `runs`
    ((quads, mode), Text) drawn over it."""
    ctx = gl.ctx
    uploads = Uploads(ctx)           # this image's own: outside any session's frame
    height, width = display8.shape[:2]
    rgba = display8.astype(np.float32) / 255.0
    rgba[..., :3] *= rgba[..., 3:]
    owned = []
    try:
        target = uploads.texture((width, height), 4, rgba, kind="overlays", dtype="f4")
        owned.append(target)
        fbo = ctx.framebuffer([target])
        owned.append(fbo)
        fbo.use()
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA
        for sprite in sprites:
            _draw_sprite(gl, uploads, sprite, width, height, owned)
        for (quads, mode), text in runs:
            _draw_text(gl, uploads, quads, mode, text, atlas, width, height, owned)
        out = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32)
        out = out.reshape(height, width, 4).copy()
    finally:
        ctx.disable(moderngl.BLEND)
        gl.scratch.use()
        for thing in reversed(owned):
            thing.release()
    alpha = out[..., 3:]
    out[..., :3] = np.where(alpha > 0, out[..., :3] / np.maximum(alpha, 1e-12), 0.0)
    return np.round(np.clip(out, 0.0, 1.0) * 255.0).astype(np.uint8)


def _quads_vao(gl, uploads, prog, quads, owned):
    """Two triangles per quad from (N, 8) rows: x0 y0 x1 y1 u0 v0 u1 v1."""
    x0, y0, x1, y1, u0, v0, u1, v1 = quads.T
    corners = [(x0, y0, u0, v0), (x1, y0, u1, v0), (x1, y1, u1, v1),
               (x0, y0, u0, v0), (x1, y1, u1, v1), (x0, y1, u0, v1)]
    vertices = np.stack([np.stack(c, axis=-1) for c in corners], axis=1)
    vbo = uploads.buffer(np.ascontiguousarray(vertices, np.float32), kind="overlays")
    owned.append(vbo)
    vao = gl.ctx.vertex_array(prog, [(vbo, "2f 2f", "in_pos", "in_uv")])
    owned.append(vao)
    return vao


def _draw_sprite(gl, uploads, sprite, width, height, owned):
    pixels = np.ascontiguousarray(sprite.pixels, np.uint8)
    h, w = pixels.shape[:2]
    tex = uploads.texture((w, h), 4, pixels, kind="overlays")
    owned.append(tex)
    tex.repeat_x = tex.repeat_y = False
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    x, y, sw, sh = sprite.rect(width, height)
    prog = gl.programs.get("overlay.vert", "overlay_sprite.frag")
    set_uniform(prog, "u_size", (float(width), float(height)))
    set_uniform(prog, "u_opacity", float(sprite.opacity))
    tex.use(UNITS["overlay_image"])
    _quads_vao(gl, uploads, prog, np.array([[x, y, x + sw, y + sh, 0, 0, w, h]], np.float32),
               owned).render(moderngl.TRIANGLES)


def _draw_text(gl, uploads, quads, mode, text, atlas, width, height, owned):
    if len(quads) == 0:
        return
    image = atlas["sdf"] if mode == "sdf" else atlas[f"bitmap_{int(text.size)}"]
    tex = uploads.texture((image.shape[1], image.shape[0]), 1, np.ascontiguousarray(image),
                          kind="overlays", alignment=1)
    owned.append(tex)
    tex.repeat_x = tex.repeat_y = False
    smooth = moderngl.LINEAR if mode == "sdf" else moderngl.NEAREST
    tex.filter = (smooth, smooth)
    prog = gl.programs.get("overlay.vert", "overlay_text.frag",
                           defines=("BITMAP",) if mode == "bitmap" else ())
    set_uniform(prog, "u_size", (float(width), float(height)))
    set_uniform(prog, "u_color", tuple(float(c) for c in text.color))
    set_uniform(prog, "u_halo_color", tuple(float(c) for c in text.halo_color))
    # One distance unit is 2 x spread atlas texels; one texel is size / em pixels.
    set_uniform(prog, "u_px_range", 2.0 * float(atlas["spread"]) * text.size / float(atlas["em"]))
    set_uniform(prog, "u_halo_width", halo_width(text.size))
    tex.use(UNITS["overlay_atlas"])
    _quads_vao(gl, uploads, prog, quads, owned).render(moderngl.TRIANGLES)
