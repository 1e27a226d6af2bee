"""Writing and reading the engine's float images.

.exr: float32 RGBA, scene-linear. .png: 8-bit through Blender's "Standard" view
transform (clamp to [0, 1], then the sRGB OETF), alpha kept linear. Writes are atomic:
a temp file in the same folder, then os.replace."""
from __future__ import annotations

import os

import numpy as np

from ..core.files import atomic_write


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def _write_exr(path, rgba):
    import OpenEXR
    channels = {"RGBA": np.ascontiguousarray(rgba, dtype=np.float32)}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(path)


def to_srgb8(rgba: np.ndarray) -> np.ndarray:
    """Scene-linear RGBA -> 8-bit through Blender's Standard view (sRGB), alpha kept."""
    out = np.empty(rgba.shape, dtype=np.uint8)
    out[..., :3] = np.round(linear_to_srgb(rgba[..., :3]) * 255.0)
    out[..., 3] = np.round(np.clip(rgba[..., 3], 0.0, 1.0) * 255.0)
    return out


def _write_png(path, rgba):
    import imageio.v3 as iio
    iio.imwrite(path, to_srgb8(rgba), extension=".png")


def write_image(path: str, rgba: np.ndarray) -> None:
    """Write float (H, W, 4) scene-linear RGBA, row 0 = top, to .exr or .png."""
    ext = os.path.splitext(path)[1].lower()
    writers = {".exr": _write_exr, ".png": _write_png}
    if ext not in writers:
        raise ValueError(f"unknown image extension {ext!r} for {path}; use .exr or .png")
    rgba = np.asarray(rgba, dtype=np.float32)
    if rgba.ndim != 3 or rgba.shape[2] != 4:
        raise ValueError(f"expected an (H, W, 4) image, got {rgba.shape}")
    atomic_write(path, lambda tmp: writers[ext](tmp, rgba), suffix=ext)


def write_animation(path: str, frames, fps: float) -> None:
    """An animated .gif preview of scene-linear RGBA frames (sRGB, looping), atomically."""
    import imageio.v3 as iio
    if not path.lower().endswith(".gif"):
        raise ValueError(f"animated previews are .gif files, not {path}")
    images = [to_srgb8(np.asarray(f, dtype=np.float32))[..., :3] for f in frames]
    atomic_write(path, lambda tmp: iio.imwrite(tmp, images, extension=".gif",
                                               duration=1000.0 / fps, loop=0), suffix=".gif")


def read_exr(path: str) -> np.ndarray:
    """An EXR as float32 (H, W, C) with C = 4 (RGBA) or 3."""
    import OpenEXR
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGBA" in ch:
            return np.array(ch["RGBA"].pixels, dtype=np.float32)
        if "RGB" in ch:
            return np.array(ch["RGB"].pixels, dtype=np.float32)
        names = [n for n in ("R", "G", "B", "A") if n in ch]
        return np.stack([np.array(ch[n].pixels, dtype=np.float32) for n in names], axis=-1)
