"""Material images as GL textures, kept for the session and uploaded once.

sRGB data goes up as GL_SRGB8_ALPHA8 so the sampler decodes to linear before
filtering (and mips are built in linear light); float images go up as float16.
Trilinear filtering with anisotropy, wrap modes via samplers (mirror and black are
finished in the shader, see gbuffer.frag sample_map). Reading the files is
engine/textures.py's job; an image that cannot be read (corrupt, truncated, empty,
not an image) becomes a magenta texel and a warning naming the file, here and only
here (`_image`), whatever the reader raises."""
from __future__ import annotations

import numpy as np

from ..textures import is_srgb, read_image_linear, read_rgba, srgb_to_linear

GL_SRGB8_ALPHA8 = 0x8C43


class MaterialTextures:
    def __init__(self, ctx, uploads, anisotropy: float):
        self.ctx, self.uploads = ctx, uploads
        self.anisotropy = anisotropy
        self._tex = {}
        self._samplers = {}
        self._dome = None              # (path, texture)
        self.failed = {}               # path -> warning: images that could not be read

    def get(self, path: str, colorspace: str):
        key = (path, colorspace)
        if key not in self._tex:
            self._tex[key] = self._upload(path, colorspace)
        return self._tex[key]

    def _image(self, path):
        """The file's pixels, or a magenta texel when it cannot be read: the one place
        the engine's image-reading errors are caught (engine/image_io raises ImageError,
        a ValueError, naming the file; the file system raises OSError)."""
        try:
            img = read_rgba(path)
            if img.ndim != 3 or img.shape[0] < 1 or img.shape[1] < 1:
                raise ValueError(f"an image of shape {img.shape}")
            return img
        except (ValueError, OSError) as exc:
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            self.failed[path] = f"{path}: cannot be read as an image ({reason}); magenta used"
            return np.array([[[255, 0, 255, 255]]], np.uint8)

    def _upload(self, path, colorspace):
        img = self._image(path)
        img = np.ascontiguousarray(img[::-1])  # GL's t = 0 is the bottom row, as USD st
        h, w = img.shape[:2]
        srgb = is_srgb(img, colorspace)
        if img.dtype == np.uint8:
            fmt = GL_SRGB8_ALPHA8 if srgb else None
            tex = self.uploads.texture((w, h), 4, img, kind="textures", dtype="f1",
                                       internal_format=fmt)
        else:
            f = img.astype(np.float32)
            if img.dtype.kind in "ui":
                f /= np.iinfo(img.dtype).max
            if srgb:
                f[..., :3] = srgb_to_linear(f[..., :3])
            tex = self.uploads.texture((w, h), 4, f.astype(np.float16), kind="textures", dtype="f2")
        tex.build_mipmaps()
        tex.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)
        tex.anisotropy = self.anisotropy
        return tex

    def sampler(self, wrap_s: str, wrap_t: str):
        """Repeat for repeat/mirror (mirror folds st in the shader), clamp-to-edge for
        clamp/black (black masks outside [0,1] in the shader)."""
        key = (wrap_s in ("repeat", "mirror"), wrap_t in ("repeat", "mirror"))
        if key not in self._samplers:
            self._samplers[key] = self.ctx.sampler(
                repeat_x=key[0], repeat_y=key[1],
                filter=(self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR),
                anisotropy=self.anisotropy, compare_func="")
        return self._samplers[key]

    def dome(self, path: str):
        """The environment's lat-long image, linear float32, kept while it is the dome's."""
        if self._dome is not None and self._dome[0] == path:
            return self._dome[1]
        if self._dome is not None:
            self._dome[1].release()
        img = np.ascontiguousarray(read_image_linear(path, "auto"), np.float32)
        tex = self.uploads.texture((img.shape[1], img.shape[0]), 4, img, kind="textures", dtype="f4")
        tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        tex.repeat_y = False
        self._dome = (path, tex)
        return tex

    def prune(self, materials):
        """Releases the images no material uses any more."""
        used = {(ref.path, ref.colorspace) for m in materials for ref in m.maps.values()}
        for key in [k for k in self._tex if k not in used]:
            self._tex.pop(key).release()
            if not any(k[0] == key[0] for k in self._tex):
                self.failed.pop(key[0], None)

    def release(self):
        for t in self._tex.values():
            t.release()
        for s in self._samplers.values():
            s.release()
        if self._dome is not None:
            self._dome[1].release()
        self._tex.clear()
        self._samplers.clear()
        self._dome = None
