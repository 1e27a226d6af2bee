"""Images -> GL textures. sRGB data goes up as GL_SRGB8_ALPHA8 so the sampler decodes
to linear before filtering (and mips are built in linear light); float images go up
as float16. Trilinear filtering with anisotropy, wrap modes via samplers (mirror and
black are finished in the shader, see lib.glsl sample_map). Cached by (path,
colourspace) for one render."""
from __future__ import annotations

import numpy as np

from .image_io import read_image

GL_SRGB8_ALPHA8 = 0x8C43


def srgb_to_linear(x):
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def _read(path: str) -> np.ndarray:
    return read_image(path)


def _rgba(img: np.ndarray) -> np.ndarray:
    if img.ndim == 2:
        img = img[..., None]
    c = img.shape[2]
    if c == 1:
        img = np.concatenate([img, img, img], axis=2)
    elif c == 2:  # grey + alpha
        img = np.concatenate([img[..., :1]] * 3 + [img[..., 1:2]], axis=2)
    if img.shape[2] == 3:
        one = np.iinfo(img.dtype).max if img.dtype.kind in "ui" else 1.0
        img = np.concatenate([img, np.full(img.shape[:2] + (1,), one, img.dtype)], axis=2)
    return img[..., :4]


def is_srgb(img: np.ndarray, colorspace: str) -> bool:
    # `auto`: integer images are taken as sRGB-encoded, float images as linear.
    if colorspace == "sRGB":
        return True
    if colorspace == "raw":
        return False
    return img.dtype.kind in "ui"


def read_image_linear(path: str, colorspace: str) -> np.ndarray:
    """float32 (H, W, 4) linear values, row 0 = top of the image."""
    img = _rgba(_read(path))
    srgb = is_srgb(img, colorspace)
    if img.dtype.kind in "ui":
        img = img.astype(np.float32) / np.iinfo(img.dtype).max
    img = img.astype(np.float32)
    if srgb:
        img[..., :3] = srgb_to_linear(img[..., :3])
    return img


class TextureCache:
    def __init__(self, ctx, anisotropy: float):
        self.ctx = ctx
        self.anisotropy = anisotropy
        self._tex = {}
        self._samplers = {}

    def get(self, path: str, colorspace: str):
        key = (path, colorspace)
        if key not in self._tex:
            self._tex[key] = self._upload(path, colorspace)
        return self._tex[key]

    def _upload(self, path, colorspace):
        img = _rgba(_read(path))
        img = np.ascontiguousarray(img[::-1])  # GL's t = 0 is the bottom row, as USD st
        h, w = img.shape[:2]
        srgb = is_srgb(img, colorspace)
        if img.dtype == np.uint8:
            fmt = GL_SRGB8_ALPHA8 if srgb else None
            tex = self.ctx.texture((w, h), 4, img.tobytes(), dtype="f1", internal_format=fmt)
        else:
            f = img.astype(np.float32)
            if img.dtype.kind in "ui":
                f /= np.iinfo(img.dtype).max
            if srgb:
                f[..., :3] = srgb_to_linear(f[..., :3])
            tex = self.ctx.texture((w, h), 4, f.astype(np.float16).tobytes(), dtype="f2")
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

    def release(self):
        for t in self._tex.values():
            t.release()
        for s in self._samplers.values():
            s.release()
        self._tex.clear()
        self._samplers.clear()
