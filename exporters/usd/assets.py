"""How image files are named in the layer: relative, absolute, or copied."""
import os
import shutil

from ...core.files import atomic_write


def asset_resolver(layer_path, mode="reference"):
    """A function file -> asset path string.

    With no layer path (an in-memory stage) paths stay absolute. Otherwise they are
    relative to the layer's folder; in "copy" mode the file is first copied into
    `<layer stem>_textures/`."""
    if layer_path is None:
        return lambda file: file.replace(os.sep, "/")
    folder = os.path.dirname(os.path.abspath(layer_path))
    stem = os.path.splitext(os.path.basename(layer_path))[0]
    copies = {}

    def resolve(file):
        if mode == "copy":
            if file not in copies:
                target_dir = os.path.join(folder, stem + "_textures")
                os.makedirs(target_dir, exist_ok=True)
                base, ext = os.path.splitext(os.path.basename(file))
                name, n = base + ext, 1
                taken = set(copies.values())
                while os.path.join(target_dir, name) in taken:
                    name, n = f"{base}_{n}{ext}", n + 1
                target = os.path.join(target_dir, name)
                if os.path.abspath(file) != os.path.abspath(target):
                    atomic_write(target, lambda tmp, src=file: shutil.copyfile(src, tmp),
                                 suffix=ext)
                copies[file] = target
            file = copies[file]
        rel = os.path.relpath(file, folder).replace(os.sep, "/")
        return rel if rel.startswith("../") else "./" + rel

    return resolve
