"""Lantern: Blender scenes to USD, rendered by a realtime deferred engine.

This folder is the Blender extension and the Python package `lantern` at once.
Blender-facing code is imported lazily in `register()`, so that `lantern.engine`
stays importable in processes without Blender (the CLI, tests, the render worker).
"""


def register():
    from . import addon
    addon.register()


def unregister():
    from . import addon
    addon.unregister()
