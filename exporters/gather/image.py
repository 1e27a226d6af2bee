"""Finds, or writes, the file behind a Blender image.

Images on disk are used in place. Packed and generated images have no file of their
own, so they are written out: into `texture_dir` (the layer's `<stem>_textures/` for a
file export, with either --textures mode), or, for a stage that lives only in memory
(rendering a .blend, F12), into one temporary folder of this process that is removed
when the process exits. There the file names carry a hash of the content, so exporting
the same scene again (every F12) reuses the files instead of piling up copies.
- packed: the packed bytes, as they are (the original PNG/JPEG/EXR...);
- generated (or painted, not yet saved): the pixels Blender holds, exactly: 8-bit
  images as an 8-bit PNG of the stored (colour-space-encoded) bytes, float images as
  a float32 EXR. Never through save_render, which would bake the scene's view
  transform into a texture.
"""
import atexit
import hashlib
import os
import re
import shutil
import tempfile

import bpy
import numpy as np

from ...core.files import atomic_write, write_bytes

_memory_dir = None
# Blender's file formats -> extensions, for packed images with no file name of their own.
EXTENSIONS = {"PNG": ".png", "JPEG": ".jpg", "OPEN_EXR": ".exr", "OPEN_EXR_MULTILAYER": ".exr",
              "HDR": ".hdr", "TIFF": ".tif", "TARGA": ".tga", "TARGA_RAW": ".tga", "BMP": ".bmp",
              "WEBP": ".webp", "JPEG2000": ".jp2", "CINEON": ".cin", "DPX": ".dpx"}


def memory_texture_dir():
    """This process's folder for images of in-memory stages (made on first use)."""
    global _memory_dir
    if _memory_dir is None:
        _memory_dir = tempfile.mkdtemp(prefix="lantern-images-")
        atexit.register(shutil.rmtree, _memory_dir, True)
    return _memory_dir


def image_file(image, owner, warn, texture_dir, udim=False):
    """Absolute path of a file holding `image`, or None with a warning naming `owner`.
    `udim`: a UDIM image of several tiles named by `<UDIM>` keeps that token (USD's
    UDIM path: the tiles are the files with 1001, 1002, ... in its place); otherwise
    its first tile stands for it."""
    if image is None:
        return None
    if image.packed_file is None and image.source in {"FILE", "SEQUENCE", "MOVIE", "TILED"}:
        path = os.path.normpath(bpy.path.abspath(image.filepath, library=image.library))
        if image.source == "TILED":
            tiled = _tiles(image, path, owner, warn) if udim else None
            if tiled is not None:
                return tiled
            path = _first_tile(image, path, owner, warn)
        if os.path.isfile(path):
            return path
        warn(f"{owner}: image file not found: {path}")
        return None
    in_memory = texture_dir is None
    folder = memory_texture_dir() if in_memory else texture_dir
    os.makedirs(folder, exist_ok=True)
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.splitext(image.name)[0]) or "image"
    try:
        if image.packed_file is not None:
            data = image.packed_file.data
            ext = os.path.splitext(image.filepath)[1] or EXTENSIONS.get(image.file_format, ".png")
            return _write(folder, stem, ext, data, in_memory,
                          lambda path: write_bytes(path, data))
        return _write_pixels(image, folder, stem, in_memory)
    except (OSError, RuntimeError, ValueError) as error:
        warn(f"{owner}: image '{image.name}' could not be written out ({error})")
        return None


def _tiles(image, path, owner, warn):
    """The `<UDIM>` path of a UDIM image of several tiles whose files exist (those that
    do not are named in a warning), or None: one tile, `<UVTILE>` naming (USD has no
    such token), or no tile file at all."""
    tiles = sorted(t.number for t in image.tiles)
    if len(tiles) < 2 or "<UDIM>" not in path:
        return None
    missing = [t for t in tiles if not os.path.isfile(path.replace("<UDIM>", str(t)))]
    if len(missing) == len(tiles):
        return None
    if missing:
        warn(f"{owner}: UDIM image '{image.name}': no file for tile(s) "
             f"{', '.join(map(str, missing))}; those tiles draw the first tile's image")
    return path


def _first_tile(image, path, owner, warn):
    """A UDIM image's first tile's file (its <UDIM> or <UVTILE> token filled in), where
    the image is drawn as one texture: in a node network, an environment, or named by
    `<UVTILE>`. The other tiles are left out, with a warning."""
    tiles = sorted(t.number for t in image.tiles) or [1001]
    first = tiles[0]
    u, v = (first - 1001) % 10 + 1, (first - 1001) // 10 + 1
    path = path.replace("<UDIM>", str(first)).replace("<UVTILE>", f"u{u}_v{v}")
    if len(tiles) > 1:
        warn(f"{owner}: UDIM image '{image.name}' has {len(tiles)} tiles; only tile "
             f"{first} is exported (UDIM tiles are drawn only for an image straight on "
             f"a surface input, named by <UDIM>)")
    return path


def _write(folder, stem, ext, content, hashed, write):
    """Write once per content: `<stem>-<hash><ext>` in memory folders, `<stem><ext>`
    (overwritten) in a layer's texture folder."""
    if hashed:
        stem = f"{stem}-{hashlib.sha1(content).hexdigest()[:12]}"
    path = os.path.join(folder, stem + ext)
    if hashed and os.path.isfile(path):
        return path
    atomic_write(path, write, suffix=ext)
    return path


def _write_pixels(image, folder, stem, hashed):
    width, height = image.size
    if width == 0 or height == 0:
        raise ValueError("the image has no pixels")
    pixels = np.empty(width * height * 4, np.float32)
    image.pixels.foreach_get(pixels)
    rgba = pixels.reshape(height, width, 4)[::-1]            # Blender's row 0 is the bottom
    if image.is_float:
        data, ext, kind = np.ascontiguousarray(rgba), ".exr", "float"
    else:
        data, ext, kind = np.round(np.clip(rgba, 0, 1) * 255).astype(np.uint8), ".png", "uint8"
    import OpenImageIO as oiio

    def write(path):
        spec = oiio.ImageSpec(width, height, 4, kind)
        spec.attribute("oiio:UnassociatedAlpha", 1)
        if kind == "float":
            spec.attribute("compression", "zip")
        out = oiio.ImageOutput.create(path)
        if out is None or not out.open(path, spec) or not out.write_image(data):
            raise OSError(oiio.geterror() or (out.geterror() if out else "no writer"))
        out.close()
    return _write(folder, stem, ext, data.tobytes(), hashed, write)
