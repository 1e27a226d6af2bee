"""A mip-mapped copy of the lit opaque frame, for the passes that read the frame where
a ray leaving a surface meets it (the glossy bounce's reflections, the glass pass's
light from behind) while they draw into it. Its mip levels blur it by a cone's
footprint: a rough lobe reads a coarser level."""
from __future__ import annotations

import math


class LitCopy:
    def __init__(self, ctx, pool):
        self.ctx, self.pool = ctx, pool
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
        tex.build_mipmaps()
        return tex

    @property
    def lods(self) -> float:
        """The copy's coarsest mip level."""
        return float(math.floor(math.log2(max(self.texture.size))))

    def release(self):
        if self.texture is not None:
            self.fbo.release()
            self.texture.release()
            self.texture = self.fbo = None
