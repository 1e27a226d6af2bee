"""The Cycles reference, cached on disk: rendering it takes minutes, and it only
changes when the scene, a file it links, or a setting of the reference changes.

The key is the SHA-256 of a canonical JSON of everything the image depends on: the
.blend's bytes, each linked library's and image's bytes (or that it is missing), the
size, frame, samples, seed, mode, pixel filter, Blender's version and the recipe
version below. Entries are `<key>.exr` and `<key>.json` (the inputs and how long the
render took), written atomically, so a crash never leaves a half entry."""
from __future__ import annotations

import hashlib
import json
import os
import shutil

from .files import atomic_write, write_json

# Bump when blender_render.configure_cycles changes what a reference image holds.
RECIPE = 1


def default_dir() -> str:
    if os.environ.get("LANTERN_COMPARE_CACHE"):
        return os.environ["LANTERN_COMPARE_CACHE"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "lantern", "compare")


def file_sha256(path: str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def scene_inputs(scene_path: str, links: list) -> dict:
    """The files every reference of a scene depends on, hashed once per comparison:
    the .blend and each file it links."""
    linked = []
    for link in sorted(links, key=lambda k: (k["kind"], k["path"], k["name"])):
        present = link["exists"] and not link.get("packed") and os.path.isfile(link["resolved"])
        linked.append({"kind": link["kind"], "path": link["path"],
                       "sha256": file_sha256(link["resolved"]) if present
                       else ("packed" if link.get("packed") else "missing")})
    return {"scene_sha256": file_sha256(scene_path), "links": linked}


def reference_inputs(scene: dict, settings: dict) -> dict:
    """What one reference depends on (the cache key is its hash): `scene_inputs` and
    the reference's settings."""
    return {"recipe": RECIPE, **scene, **settings}


def key_of(inputs: dict) -> str:
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


class ReferenceCache:
    def __init__(self, folder: str):
        self.folder = folder

    def _paths(self, key):
        return os.path.join(self.folder, key + ".exr"), os.path.join(self.folder, key + ".json")

    def lookup(self, key: str) -> dict | None:
        """The entry's metadata (with "image": its path), or None on a miss."""
        image, meta = self._paths(key)
        if not (os.path.isfile(image) and os.path.isfile(meta)):
            return None
        with open(meta, encoding="utf-8") as f:
            entry = json.load(f)
        return entry | {"image": image}

    def store(self, key: str, image_path: str, meta: dict) -> None:
        image, meta_path = self._paths(key)
        os.makedirs(self.folder, exist_ok=True)
        atomic_write(image, lambda tmp: shutil.copyfile(image_path, tmp), suffix=".exr")
        write_json(meta_path, meta)  # last: an entry counts only once both are there
