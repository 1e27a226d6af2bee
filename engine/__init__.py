"""USD to pixels: pxr, numpy and moderngl. Never imports bpy.

The engine owns its own headless GL context on a dedicated thread and returns
scene-linear float images; it never touches Blender's GL context.
"""
from .api import (RenderResult, RenderSettings, render_file, render_sequence,  # noqa: F401
                  render_stage, skinned_points)
from .gl_thread import shutdown  # noqa: F401
from .image_io import read_exr, write_image  # noqa: F401

__all__ = ["RenderResult", "RenderSettings", "render_file", "render_sequence", "render_stage",
           "skinned_points", "shutdown",
           "read_exr", "write_image"]
