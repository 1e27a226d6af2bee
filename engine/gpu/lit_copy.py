"""A mip-mapped copy of the lit opaque frame, for the passes that read the frame where
a ray leaving a surface meets it (the glossy bounce's reflections, the glass pass's
light from behind) while they draw into it. Its mip levels blur it by a cone's
footprint: a rough lobe reads a coarser level.

The levels are made by a program of Lantern's (shaders/lit_mips.comp: each texel the
mean of the 2 x 2 above it), which the program cache and the driver's shader cache
keep, and not by glGenerateMipmap: llvmpipe builds a blit shader for that, per format,
in every new process (0.15 s of CPU in a cold render's first frame), which no cache
keeps. Without compute shaders (GL 3.3, 4.1) the driver generates them."""
from __future__ import annotations

import ctypes
import math

from .programs import UNITS, set_uniform
from .stencil import entry_points

GROUP = 8                          # shaders/lit_mips.comp's local size
GL_TEXTURE_2D, GL_TEXTURE0, GL_RGBA32F, GL_RGBA, GL_FLOAT = \
    0x0DE1, 0x84C0, 0x8814, 0x1908, 0x1406
_u, _i = ctypes.c_uint, ctypes.c_int
_SIGS = {"glActiveTexture": (None, _u), "glBindTexture": (None, _u, _u),
         "glTexImage2D": (None, _u, _i, _i, _i, _i, _i, _u, _u, ctypes.c_void_p)}


def level_sizes(size) -> list:
    """The sizes of a texture's mip levels below level 0, as GL gives them (halved,
    floored, at least 1), down to 1 x 1."""
    w, h = size
    sizes = []
    while w > 1 or h > 1:
        w, h = max(w // 2, 1), max(h // 2, 1)
        sizes.append((w, h))
    return sizes


class LitCopy:
    def __init__(self, ctx, pool, programs, proc, compute: bool):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.compute = compute         # levels by lit_mips.comp; else glGenerateMipmap
        self._gl = entry_points(proc, _SIGS) if compute else None
        self.texture = None            # kept while the frame's size stays
        self.fbo = None                # the copy as a framebuffer, to blit into

    def made(self, hdr):
        """The copy's texture at `hdr`'s size (its contents those of the last copy)."""
        if self.texture is None or self.texture.size != hdr.size:
            self.release()
            self.texture = self.ctx.texture(hdr.size, 4, dtype="f4")
            self.fbo = self.ctx.framebuffer(color_attachments=[self.texture])
            self.texture.repeat_x = self.texture.repeat_y = False
            self.texture.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)
            if self.compute:
                self._allocate_levels()
        return self.texture

    def copy(self, hdr):
        """`hdr` as it is now, copied and its mip levels made."""
        tex = self.made(hdr)
        # The clustered light pass stores into the frame as an image: a framebuffer read
        # sees those stores only after a barrier.
        self.ctx.memory_barrier()
        # Framebuffer to framebuffer (a blit): exact. Into the texture itself (a copy
        # to a texture image) llvmpipe rounds the floats to 8 bits.
        self.ctx.copy_framebuffer(self.fbo, self.pool.framebuffer([hdr]))
        if self.compute:
            self._make_levels()
        else:
            tex.build_mipmaps()
        return tex

    def _allocate_levels(self):
        """Storage for every level below 0, unwritten (ModernGL allocates levels only by
        generating them)."""
        gl = self._gl
        gl["glActiveTexture"](GL_TEXTURE0 + self.ctx.default_texture_unit)  # as ModernGL's
        gl["glBindTexture"](GL_TEXTURE_2D, self.texture.glo)
        for level, (w, h) in enumerate(level_sizes(self.texture.size), 1):
            gl["glTexImage2D"](GL_TEXTURE_2D, level, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT,
                               None)

    def _make_levels(self):
        """Each level from the one above it, in order (a barrier between: the next
        level reads what the last one stored)."""
        prog = self.programs.get("lit_mips.comp", None, [], compute=True)
        self.texture.use(UNITS["hdr"])
        set_uniform(prog, "u_lit", UNITS["hdr"])
        for level, (w, h) in enumerate(level_sizes(self.texture.size), 1):
            set_uniform(prog, "u_level", level - 1)
            self.texture.bind_to_image(0, read=False, write=True, level=level)
            prog.run(-(-w // GROUP), -(-h // GROUP))
            self.ctx.memory_barrier()

    @property
    def lods(self) -> float:
        """The copy's coarsest mip level."""
        return float(math.floor(math.log2(max(self.texture.size))))

    def release(self):
        if self.texture is not None:
            self.fbo.release()
            self.texture.release()
            self.texture = self.fbo = None
