"""Material and environment images read from files, as numpy: RGBA in the file's own
precision, and whether to take it as sRGB-encoded. The GL side
(engine/gpu/textures.py) uploads them."""
from __future__ import annotations

import numpy as np

from .image_io import read_image


def srgb_to_linear(x):
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def read_rgba(path: str) -> np.ndarray:
    """(H, W, 4) RGBA in the file's own precision (grey, grey+alpha and RGB filled in)."""
    return _rgba(read_image(path))


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
    return linear(read_rgba(path), colorspace)


def linear(img: np.ndarray, colorspace: str) -> np.ndarray:
    """float32 linear values of RGBA `img` in its file's precision."""
    srgb = is_srgb(img, colorspace)
    if img.dtype.kind in "ui":
        img = img.astype(np.float32) / np.iinfo(img.dtype).max
    img = img.astype(np.float32)
    if srgb:
        img[..., :3] = srgb_to_linear(img[..., :3])
    return img


def linear_mean(img: np.ndarray, colorspace: str) -> np.ndarray:
    """(4,) float64: the mean of linear(img, colorspace) over its texels. An 8-bit
    image's from its histogram: one decode per byte value, not per texel."""
    if img.dtype != np.uint8:
        return linear(img, colorspace).reshape(-1, 4).mean(axis=0, dtype=np.float64)
    values = linear(np.repeat(np.arange(256, dtype=np.uint8)[None, :, None], 4, axis=2),
                    colorspace)[0].astype(np.float64)                     # (256, 4)
    counts = np.stack([np.bincount(img[..., c].ravel(), minlength=256) for c in range(4)], 1)
    return (values * counts).sum(axis=0) / (img.shape[0] * img.shape[1])


def map_value(ref, rgba) -> np.ndarray:
    """What a map (a TextureRef) gives a surface input for linear texel values `rgba`
    (..., 4): times its scale plus its bias, then the channel it names alone, on all
    three (UsdUVTexture's outputs), else rgb. The CPU twin of shaders/material.glsl's
    sample_map, for what reads a map's value off the GPU (a texture's mean)."""
    v = np.asarray(rgba, np.float64) * np.asarray(ref.scale, np.float64) + \
        np.asarray(ref.bias, np.float64)
    if ref.channel in ("r", "g", "b", "a"):
        return np.repeat(v[..., "rgba".index(ref.channel), None], 3, axis=-1)
    return v[..., :3]
