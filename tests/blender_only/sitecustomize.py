"""Makes this Python import modules as a real Blender would: a bpy process of the
install test (tests/_addon_host.py) loads this file itself, and the engine host's
child process it starts gets it through PYTHONPATH, where Python's `site` imports a
`sitecustomize` at start-up. So both processes lack what Blender lacks.

- Names a real Blender does not ship (the brief's list, and `lantern`, so the add-on
  comes from the installed extension, never the editable install) are unimportable.
- Of the venv's site-packages only bpy's own bundle (bpy and what it requires,
  transitively: numpy and friends, which Blender ships) is importable; anything else
  found there (usd-core's pxr, moderngl, glcontext, imageio, ...) must come from
  another sys.path entry (Blender's bundled site-packages, the extension's wheels) or
  is unimportable.
"""
import importlib.abc
import importlib.machinery
import importlib.metadata
import os
import re
import sys
import sysconfig

NOT_IN_BLENDER = ("imageio", "OpenEXR", "Imath", "PIL", "rich", "jsonschema", "dask",
                  "flip_evaluator", "skimage", "matplotlib", "tqdm", "lantern")


def _norm(name):
    return re.sub(r"[-_.]+", "-", name).lower()


def _bpy_bundle():
    """Top-level modules of bpy and of what bpy requires, transitively."""
    wanted, todo = set(), ["bpy"]
    while todo:
        dist = _norm(todo.pop())
        if dist in wanted:
            continue
        wanted.add(dist)
        for req in importlib.metadata.requires(dist) or ():
            if "extra ==" not in req:
                todo.append(re.match(r"[A-Za-z0-9._-]+", req).group(0))
    return {module for module, dists in importlib.metadata.packages_distributions().items()
            if any(_norm(d) in wanted for d in dists)}


class BlenderBundleOnly(importlib.abc.MetaPathFinder):
    def __init__(self):
        self.venv = os.path.normpath(sysconfig.get_paths()["purelib"])
        self.allowed = _bpy_bundle()
        self.hidden = set(NOT_IN_BLENDER)

    def find_spec(self, name, path=None, target=None):
        if path is not None:
            return None  # submodules follow their parent package
        if name in self.hidden:
            raise ModuleNotFoundError(f"No module named {name!r} (not in Blender)", name=name)
        if name in self.allowed:
            return None
        if importlib.machinery.PathFinder.find_spec(name, [self.venv]) is None:
            return None
        others = [p for p in sys.path if os.path.normpath(p or os.getcwd()) != self.venv]
        spec = importlib.machinery.PathFinder.find_spec(name, others)
        if spec is None:
            raise ModuleNotFoundError(f"No module named {name!r} (only in the venv)", name=name)
        return spec


if not any(isinstance(f, BlenderBundleOnly) for f in sys.meta_path):
    sys.meta_path.insert(0, BlenderBundleOnly())
