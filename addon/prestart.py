"""Starts the engine host before the first F12 or viewport draw, so that neither pays
the process start: when the add-on registers, when a file is loaded, and when Lantern
becomes a scene's render engine, if some scene renders with Lantern. The host then
warms its programs up (engine/host/warmup.py) while the user works. A start that
fails is the host's `failure`, reported by the render that needs it."""
import bpy

from . import host as host_module

ENGINE = "LANTERN"
_owner = object()           # the msgbus subscription's owner


def used() -> bool:
    """True when some scene of the open file renders with Lantern."""
    return any(scene.render.engine == ENGINE for scene in getattr(bpy.data, "scenes", ()))


def start_if_used():
    """Starts the host in the background if a scene needs it (Popen only: the child
    boots and warms up on its own). Returns None, so that a timer runs it once."""
    if used():
        host_module.get().ensure()
    return None


@bpy.app.handlers.persistent
def _loaded(*_):
    _subscribe()            # a file load clears msgbus subscriptions
    start_if_used()


def _subscribe():
    bpy.msgbus.clear_by_owner(_owner)
    bpy.msgbus.subscribe_rna(key=(bpy.types.RenderSettings, "engine"), owner=_owner, args=(),
                             notify=start_if_used)


def register():
    bpy.app.handlers.load_post.append(_loaded)
    _subscribe()
    # bpy.data is not readable while add-ons register: look right after.
    bpy.app.timers.register(start_if_used, first_interval=0.0)


def unregister():
    if bpy.app.timers.is_registered(start_if_used):
        bpy.app.timers.unregister(start_if_used)
    bpy.msgbus.clear_by_owner(_owner)
    if _loaded in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_loaded)
