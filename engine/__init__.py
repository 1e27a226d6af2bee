"""USD to pixels: pxr, numpy and moderngl. Never imports bpy.

A Session (engine/session.py) keeps a stage's scene and GPU state across renders.
engine/usd/ reads the stage into plain records (engine/scene.py); engine/gpu/ draws
them on the engine's own headless GL context, on a dedicated thread, and returns
scene-linear float images. It never touches Blender's GL context."""
from .api import render_file, render_sequence, render_stage, skinned_points  # noqa: F401
from .gpu.context import shutdown  # noqa: F401
from .image_io import read_exr, write_image  # noqa: F401
from .session import RenderResult, RenderSettings, Session  # noqa: F401

__all__ = ["RenderResult", "RenderSettings", "Session", "render_file", "render_sequence",
           "render_stage", "skinned_points", "shutdown", "read_exr", "write_image"]
