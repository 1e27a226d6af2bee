"""How image files are named in the layer: relative, absolute, or copied."""
import glob
import os
import shutil

from ...core.files import atomic_write


def asset_resolver(layer_path, mode="reference"):
    """A function file -> asset path string.

    With no layer path (an in-memory stage) paths stay absolute. Otherwise they are
    relative to the layer's folder; in "copy" mode the file is first copied into
    `<layer stem>_textures/` (every tile of a `<UDIM>` path, which keeps its token)."""
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
                for source, copy in _tile_files(file, target):
                    if os.path.abspath(source) != os.path.abspath(copy):
                        atomic_write(copy, lambda tmp, src=source: shutil.copyfile(src, tmp),
                                     suffix=ext)
                copies[file] = target
            file = copies[file]
        rel = os.path.relpath(file, folder).replace(os.sep, "/")
        return rel if rel.startswith("../") else "./" + rel

    return resolve


def _tile_files(file, target):
    """[(source, copy)]: the file itself, or each existing tile of a `<UDIM>` path."""
    if "<UDIM>" not in file:
        return [(file, target)]
    head, tail = file.split("<UDIM>", 1)
    found = glob.glob(glob.escape(head) + "[1-9][0-9][0-9][0-9]" + glob.escape(tail))
    return [(path, target.replace("<UDIM>", path[len(head):len(head) + 4])) for path in found]
