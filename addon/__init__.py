"""Blender UI: the LANTERN render engine, its properties, panels and operators."""
from . import operators, panels, prestart, properties, render_engine, scene_render

_MODULES = (properties, render_engine, panels, operators, prestart)


def register():
    for module in _MODULES:
        module.register()


def unregister():
    for module in reversed(_MODULES):
        module.unregister()
    # Nothing outlives the add-on: the engine process stops, with its threads and
    # shared memory.
    scene_render.shutdown()
