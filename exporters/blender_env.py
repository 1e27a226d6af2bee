"""Makes a bpy process use Blender's own USD.

Blender ships its own `pxr` and has already loaded its USD libraries. In a process
that imports bpy, a second USD (usd-core from PyPI) must never be loaded: two copies
of the same C++ libraries in one process corrupt each other's registries. When bpy
runs as a Python module, its `pxr` sits in Blender's bundled site-packages, which is
not on sys.path by default, so it goes first here, before anything imports pxr.
"""
import os
import sys

import bpy


def _blender_site_packages():
    local = bpy.utils.resource_path('LOCAL')
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    return os.path.join(local, "python", "lib", version, "site-packages")


def use_blenders_usd():
    """Put Blender's pxr first on sys.path; fail loudly if another pxr is loaded."""
    site = _blender_site_packages()
    if not os.path.isdir(os.path.join(site, "pxr")):
        return  # a full Blender install: its pxr is already importable
    # The same holds for Blender's OpenImageIO and PyOpenColorIO (PyPI has its own).
    for name in ("pxr", "OpenImageIO", "PyOpenColorIO"):
        loaded = sys.modules.get(name)
        if loaded is None:
            continue
        origin = os.path.dirname(os.path.abspath(loaded.__file__))
        if not origin.startswith(os.path.abspath(site)):
            raise ImportError(
                f"{name} was imported from {origin} before bpy; in a Blender process only "
                f"Blender's own ({site}) may be loaded. Import lantern.exporters first.")
    if site not in sys.path:
        sys.path.insert(0, site)


use_blenders_usd()
