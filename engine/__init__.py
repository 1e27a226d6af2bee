"""USD to pixels: pxr, numpy and moderngl. Never imports bpy.

A Session (engine/session.py) keeps a stage's scene and GPU state across renders.
engine/usd/ reads the stage into plain records (engine/scene.py); engine/gpu/ draws
them on the engine's own headless GL context, on a dedicated thread, and returns
scene-linear float images. It never touches Blender's GL context; inside Blender it
runs in its own process (engine/host/).

The names below are imported on first use, so that a process that needs one part
(Blender's side of the host: engine/host/protocol.py, engine/usd/fragments.py) does
not load moderngl."""
import importlib

_WHERE = {"render_file": ".api", "render_sequence": ".api", "render_stage": ".api",
          "skinned_points": ".api", "shutdown": ".gpu.context", "read_exr": ".image_io",
          "write_image": ".image_io", "RenderResult": ".session",
          "RenderSettings": ".settings", "Session": ".session"}

__all__ = sorted(_WHERE)


def __getattr__(name):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_WHERE[name], __name__), name)
    globals()[name] = value
    return value
