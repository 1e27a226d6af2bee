"""Blender to USD. Gathers Blender data into plain records, then writes USD.

Importing this package imports bpy and makes the process use Blender's own pxr
(see `blender_env`), so import it before anything that imports pxr.
"""
from . import blender_env  # noqa: F401  (must run before any pxr import)
