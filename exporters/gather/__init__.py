"""Blender data -> plain records (see `..ir`). Only these modules read bpy."""
