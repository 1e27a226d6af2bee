"""Blender UI: the LANTERN render engine, its properties, panels and operators."""
from . import operators, panels, properties, render_engine, scene_render

_MODULES = (properties, render_engine, panels, operators)


def register():
    for module in _MODULES:
        module.register()


def unregister():
    for module in reversed(_MODULES):
        module.unregister()
    # No thread outlives the add-on: frames in flight finish, the GL thread stops.
    scene_render.shutdown()
