"""Finds, or writes, the file behind a Blender image."""
import os
import re

import bpy


def image_file(image, owner, warn, texture_dir):
    """Absolute path of a file holding `image`, or None with a warning.

    Images on disk are used in place. Packed and generated images have no file of
    their own, so they are written into `texture_dir` (when there is one)."""
    if image is None:
        return None
    if image.packed_file is None and image.source in {"FILE", "SEQUENCE", "MOVIE", "TILED"}:
        path = os.path.normpath(bpy.path.abspath(image.filepath, library=image.library))
        if os.path.isfile(path):
            return path
        warn(f"{owner}: image file not found: {path}")
        return None
    if texture_dir is None:
        warn(f"{owner}: image '{image.name}' is packed or generated and no texture folder was given")
        return None
    os.makedirs(texture_dir, exist_ok=True)
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.splitext(image.name)[0]) or "image"
    if image.packed_file is not None:
        ext = os.path.splitext(image.filepath)[1] or "." + image.file_format.lower()
        path = os.path.join(texture_dir, stem + ext)
        with open(path, "wb") as f:
            f.write(image.packed_file.data)
        return path
    path = os.path.join(texture_dir, stem + ".png")
    # save_render writes a copy and leaves the image data-block untouched.
    scene = bpy.context.scene
    settings = scene.render.image_settings
    old = settings.file_format
    settings.file_format = "PNG"
    try:
        image.save_render(path, scene=scene)
    finally:
        settings.file_format = old
    return path
