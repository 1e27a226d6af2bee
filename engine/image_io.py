"""Reading and writing images with OpenImageIO, the library Blender itself ships.

- read_image: any format OIIO reads (PNG, TIFF, EXR, HDR, JPEG, ...) as numpy in the
  file's own precision: uint8, uint16, float16 or float32, row 0 = the top of the
  image, alpha exactly as stored (never premultiplied on the way in). Values above 1
  stay above 1. A file OIIO cannot open or decode raises ImageError naming the file.
- write_image: .exr is float32 RGBA, scene-linear; .png is 8-bit through a view
  transform (engine/color.py: Blender's Standard by default, or AgX, Filmic, Khronos PBR
  Neutral and their looks through OpenColorIO), alpha kept linear and straight.
- write_layers: the image and its render passes as one multi-layer EXR, laid out as
  Blender 5 writes its own: one part per pass, named `<view layer>.<pass>`, channels
  `<view layer>.<pass>.<letter>` (core/passes.py `title`, `file_channels`), the
  Combined part first and carrying the header metadata (Cryptomatte's manifests:
  core/cryptomatte.py). Every part float32, ZIP-compressed.
- write_animation: a looping .gif preview. Neither Blender's OpenImageIO nor PyPI's has
  a GIF writer, so the GIF is encoded here (median-cut palette, LZW): a small,
  dependency-free encoder rather than a second imaging library in the engine.

Every write goes to a temp file in the same folder and is then renamed (os.replace):
readers never see a half-written file.

Inside a bpy process `OpenImageIO` is Blender's own (exporters/blender_env.py puts
Blender's bundled site-packages first); elsewhere it is PyPI's `openimageio`, pinned to
the release closest to Blender 5.0's. The module is imported on first use only.
"""
from __future__ import annotations

import os
import struct

import numpy as np

from ..core.files import atomic_write, atomic_write_bytes
from .color import linear_to_srgb, to_display8, to_srgb8  # noqa: F401 (re-exported)


class ImageError(ValueError):
    """An image that cannot be read or written; the message names the file."""


def _oiio():
    import OpenImageIO
    return OpenImageIO


# OIIO base types kept as they are; anything else (int32, double, ...) becomes float32.
_NATIVE = {"uint8": np.uint8, "uint16": np.uint16, "half": np.float16, "float": np.float32}


def read_image(path: str) -> np.ndarray:
    """(H, W, C) numpy array of the image's first subimage, in its own precision."""
    oiio = _oiio()
    config = oiio.ImageSpec()
    # Keep stored colour values: OIIO would premultiply PNG/TIFF colour by alpha.
    config.attribute("oiio:UnassociatedAlpha", 1)
    image = oiio.ImageInput.open(str(path), config)
    if image is None:
        raise ImageError(f"{path}: cannot read image ({_last_error(oiio) or 'unknown format'})")
    try:
        spec = image.spec()
        base = str(spec.format)
        dtype = _NATIVE.get(base, np.float32)
        pixels = image.read_image(0, 0, 0, spec.nchannels, base if base in _NATIVE else "float")
        if pixels is None:
            raise ImageError(f"{path}: cannot decode image ({image.geterror() or 'truncated?'})")
    finally:
        image.close()
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.ndim != 3 or pixels.shape[:2] != (spec.height, spec.width):
        raise ImageError(f"{path}: unexpected pixel layout {pixels.shape}")
    return np.ascontiguousarray(pixels, dtype=dtype)


def read_exr(path: str) -> np.ndarray:
    """An EXR (or any image) as float32 (H, W, C); kept for tests and tools."""
    return read_image(path).astype(np.float32)


def _last_error(oiio) -> str:
    return (oiio.geterror() or "").strip().replace("\n", "; ")


def _oiio_write(path, pixels, typename, attributes=()):
    oiio = _oiio()
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, typename)
    for name, value in attributes:
        spec.attribute(name, value)
    out = oiio.ImageOutput.create(path)
    if out is None:
        raise ImageError(f"{path}: no image writer ({_last_error(oiio)})")
    try:
        if not out.open(path, spec) or not out.write_image(np.ascontiguousarray(pixels)):
            raise ImageError(f"{path}: cannot write image ({out.geterror()})")
    finally:
        out.close()


def _write_exr(path, rgba, **_):
    _oiio_write(path, rgba, "float", [("compression", "zip")])


def _write_png(path, rgba, view="Standard", look=None, exposure=0.0, overlay=None):
    pixels = to_display8(rgba, view=view, look=look, exposure=exposure)
    if overlay is not None:     # drawn on the display-referred values (engine/overlays.py)
        pixels = overlay(pixels)
    # Straight alpha, as PNG stores it: OIIO would otherwise un-premultiply. zlib's level
    # 1, Blender's for its default PNG Compression of 15%: a quarter larger than OIIO's
    # default level 6, in less than half the time (a 640x360 render: about 60 ms less).
    _oiio_write(path, pixels, "uint8", [("oiio:UnassociatedAlpha", 1),
                                        ("png:compressionLevel", 1)])


def write_image(path: str, rgba: np.ndarray, view: str = "Standard", look: str | None = None,
                exposure: float = 0.0, overlay=None) -> None:
    """Write float (H, W, 4) scene-linear RGBA, row 0 = top, to .exr or .png.

    `view`, `look` and `exposure` (stops) are Blender's colour-management settings and
    shape the .png only; an .exr is always the scene-linear values. `overlay`, a
    function of the (H, W, 4) uint8 display image (engine/overlays.py BurnIn.apply),
    draws over the .png only."""
    ext = os.path.splitext(path)[1].lower()
    writers = {".exr": _write_exr, ".png": _write_png}
    if ext not in writers:
        raise ValueError(f"unknown image extension {ext!r} for {path}; use .exr or .png")
    rgba = np.asarray(rgba, dtype=np.float32)
    if rgba.ndim != 3 or rgba.shape[2] != 4:
        raise ValueError(f"expected an (H, W, 4) image, got {rgba.shape}")
    atomic_write(path, lambda tmp: writers[ext](tmp, rgba, view=view, look=look,
                                                exposure=exposure, overlay=overlay), suffix=ext)


def write_layers(path: str, rgba: np.ndarray, passes: dict, layer: str = "ViewLayer",
                 cryptomatte: dict | None = None) -> None:
    """One multi-layer EXR of scene-linear RGBA (H, W, 4) and `passes` ({engine pass
    name: float32 (H, W, C)}, core/passes.py), row 0 = top, under view layer `layer`;
    `cryptomatte`: {matte: {name: id}} (RenderResult.cryptomatte)."""
    from ..core.cryptomatte import metadata
    from ..core.passes import COMBINED_TITLE, PASSES
    if not path.lower().endswith(".exr"):
        raise ValueError(f"{path}: render passes need an .exr")
    rgba = np.asarray(rgba, dtype=np.float32)
    h, w = rgba.shape[:2]
    parts = [(COMBINED_TITLE, "RGBA", rgba)]
    for name in sorted(passes, key=list(PASSES).index):
        p, pixels = PASSES[name], np.asarray(passes[name], dtype=np.float32)
        if pixels.shape != (h, w, p.channels):
            raise ValueError(f"pass {name}: expected {(h, w, p.channels)}, got {pixels.shape}")
        parts.append((p.title, p.file_channels, pixels))
    header = {}
    for matte, manifest in (cryptomatte or {}).items():
        header.update(metadata(f"{layer}.{matte}", manifest))
    atomic_write(path, lambda tmp: _write_parts(tmp, parts, layer, header), suffix=".exr")


def _write_parts(path, parts, layer, header):
    oiio = _oiio()
    specs = []
    for title, letters, pixels in parts:
        h, w, c = pixels.shape
        spec = oiio.ImageSpec(w, h, c, "float")
        spec.channelnames = tuple(f"{layer}.{title}.{letter}" for letter in letters)
        spec.attribute("name", f"{layer}.{title}")
        spec.attribute("compression", "zip")
        specs.append(spec)
    for name, value in header.items():
        specs[0].attribute(name, value)
    out = oiio.ImageOutput.create(path)
    if out is None:
        raise ImageError(f"{path}: no image writer ({_last_error(oiio)})")
    try:
        for i, ((_, _, pixels), spec) in enumerate(zip(parts, specs)):
            opened = out.open(path, specs) if i == 0 else \
                out.open(path, spec, "AppendSubimage")
            if not opened or not out.write_image(np.ascontiguousarray(pixels)):
                raise ImageError(f"{path}: cannot write image ({out.geterror()})")
    finally:
        out.close()


def write_animation(path: str, frames, fps: float, view: str = "Standard",
                    look: str | None = None, exposure: float = 0.0) -> None:
    """An animated, looping .gif preview of scene-linear RGBA frames, atomically."""
    if not path.lower().endswith(".gif"):
        raise ValueError(f"animated previews are .gif files, not {path}")
    images = [to_display8(np.asarray(f, dtype=np.float32), view=view, look=look,
                          exposure=exposure)[..., :3] for f in frames]
    if not images:
        raise ValueError(f"{path}: no frames to write")
    data = encode_gif(images, fps)
    atomic_write_bytes(path, data, suffix=".gif")


# --- GIF ------------------------------------------------------------------------------
# GIF89a with one global 256-colour palette shared by every frame (no palette flicker),
# the NETSCAPE2.0 loop extension, and a per-frame delay in centiseconds.

def encode_gif(images, fps: float) -> bytes:
    """Bytes of a looping GIF of (H, W, 3) uint8 frames, all the same size."""
    h, w = images[0].shape[:2]
    if any(img.shape[:2] != (h, w) for img in images):
        raise ValueError("GIF frames must all have the same size")
    palette, indices = _median_cut(np.stack([img[..., :3] for img in images]))
    delay = max(1, int(round(100.0 / fps))) if fps > 0 else 4
    out = bytearray(b"GIF89a")
    out += struct.pack("<HHBBB", w, h, 0xF7, 0, 0)   # global colour table of 256 entries
    out += palette.tobytes()
    out += b"\x21\xFF\x0BNETSCAPE2.0\x03\x01\x00\x00\x00"  # loop forever
    for frame in indices:
        out += b"\x21\xF9\x04" + struct.pack("<BHBB", 0x04, delay, 0, 0)
        out += b"\x2C" + struct.pack("<HHHHB", 0, 0, w, h, 0)
        out.append(8)                                 # LZW minimum code size
        data = _lzw(frame.astype(np.uint8).tobytes())
        for i in range(0, len(data), 255):
            chunk = data[i:i + 255]
            out.append(len(chunk))
            out += chunk
        out.append(0)
    out.append(0x3B)
    return bytes(out)


def _median_cut(pixels):
    """(256, 3) uint8 palette by median cut over all frames, and each pixel's entry.

    Pixels are grouped by their 6-bit-per-channel colour (each group keeps its exact
    mean); boxes of groups are split at the pixel-count median of their widest channel
    until there are 256; a group takes the palette colour nearest its mean."""
    flat = pixels.reshape(-1, 3)
    c6 = (flat >> 2).astype(np.int64)
    keys, inverse, counts = np.unique((c6[:, 0] << 12) | (c6[:, 1] << 6) | c6[:, 2],
                                      return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    means = np.stack([np.bincount(inverse, flat[:, k].astype(np.float64)) for k in range(3)],
                     -1) / counts[:, None]
    boxes = [np.arange(len(keys))]
    while len(boxes) < 256:
        spans = [np.ptp(means[b], axis=0).max() if len(b) > 1 else -1.0 for b in boxes]
        i = int(np.argmax(spans))
        if spans[i] <= 0:
            break
        box = boxes.pop(i)
        axis = int(np.argmax(np.ptp(means[box], axis=0)))
        box = box[np.argsort(means[box, axis], kind="stable")]
        cum = np.cumsum(counts[box])
        cut = int(np.clip(np.searchsorted(cum, cum[-1] / 2.0), 0, len(box) - 2)) + 1
        boxes += [box[:cut], box[cut:]]
    palette = np.zeros((256, 3))
    for i, box in enumerate(boxes):
        weights = counts[box][:, None]
        palette[i] = (means[box] * weights).sum(0) / weights.sum()
    palette = np.clip(np.round(palette), 0, 255)
    nearest = np.empty(len(keys), np.int64)
    for start in range(0, len(keys), 4096):
        d = ((means[start:start + 4096, None, :] - palette[None, :len(boxes)]) ** 2).sum(-1)
        nearest[start:start + 4096] = d.argmin(1)
    return palette.astype(np.uint8), nearest[inverse].reshape(pixels.shape[:-1])


def _lzw(data: bytes) -> bytes:
    """GIF's variable-width LZW of 8-bit indices (clear code 256, end 257), packed LSB first."""
    clear, end = 256, 257
    out = bytearray()
    acc = nbits = 0

    def emit(code, width):
        nonlocal acc, nbits
        acc |= code << nbits
        nbits += width
        while nbits >= 8:
            out.append(acc & 0xFF)
            acc >>= 8
            nbits -= 8

    table, next_code, width = {}, 258, 9
    emit(clear, width)
    prefix = data[0]
    for byte in data[1:]:
        key = (prefix << 8) | byte
        code = table.get(key)
        if code is not None:
            prefix = code
            continue
        emit(prefix, width)
        if next_code < 4096:
            table[key] = next_code
            next_code += 1
            if next_code > (1 << width) and width < 12:
                width += 1
        else:   # table full: start over
            emit(clear, width)
            table, next_code, width = {}, 258, 9
        prefix = byte
    emit(prefix, width)
    emit(end, width)
    if nbits:
        out.append(acc & 0xFF)
    return bytes(out)
