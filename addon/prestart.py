"""Starts the engine host before the first F12 or viewport draw, so that neither pays
the process start: when the add-on registers, when a file is loaded, and when Lantern
becomes a scene's render engine, if some scene renders with Lantern. It is then asked
to warm up (WARM): to make the programs of a first frame at the interactive preset and
at those scenes' presets (engine/host/warmup.py) while the user works. A start that
fails is the host's `failure`, reported by the render that needs it."""
import bpy

from ..engine.host import protocol
from . import host as host_module

ENGINE = "LANTERN"
_owner = object()           # the msgbus subscription's owner
_warmed = [None]            # the host generation last asked to warm up


def presets() -> list:
    """The presets a first frame of the open file is likely drawn with: those of the
    scenes that render with Lantern (F12), then the interactive one (none: [])."""
    used = [s.lantern.preset for s in getattr(bpy.data, "scenes", ())
            if s.render.engine == ENGINE]
    return list(dict.fromkeys([*used, protocol.INTERACTIVE_PRESET])) if used else []


def start_if_used():
    """Starts the host in the background if a scene needs it (Popen only: the child
    boots on its own), and asks a new one to warm up. Returns None, so that a timer
    runs it once."""
    wanted = presets()
    if wanted:
        host = host_module.get()
        try:
            if host.ensure() and host.generation != _warmed[0]:
                host.send(protocol.WARM, presets=wanted)
                _warmed[0] = host.generation
        except host_module.HostError:
            pass    # the child died at once: its `failure` goes to the render that needs it
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
