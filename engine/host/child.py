"""The engine host's child process: stages, Sessions and frames, on its own GL context.

One *scene* per stream Blender opens (a viewport, an F12 view layer, previews): an
in-memory stage that Blender's edits (fragments) keep equal to Blender's mirror, the
one Session rendering it (a progressive view draws with the interactive preset while
it moves and with the scene's once it settles: a preset change reads and uploads
nothing again), the last render request and the shared-memory slots its frames go to.

The main loop applies every message that has arrived, then renders one frame of the
scene that most needs one: a new request or edit first (the interactive preset when
the view is progressive), then a settled view's final frame, then the frames that
converge its irradiance field (RenderSettings.progressive_field). Requests that arrive
while a frame renders replace the one waiting: a moving view never queues frames.
A reader thread receives messages meanwhile, so Blender's sends never wait on a
render."""
from __future__ import annotations

import importlib.util
import os
import queue
import sys
import threading
import time
import traceback
from multiprocessing import connection

from ...core.passes import PASSES
from . import protocol


class Scene:
    def __init__(self):
        from ..usd.fragments import receiver
        self.stage = receiver()
        self._session = None       # made at the first render
        self.request = None        # the last render request (its fields)
        self.level = 0             # 0: to render, 1: interactive frame shown, 2: done
        self.touched = 0.0         # when the request or the stage last changed
        self.blocks = {}           # slot name -> SharedMemory
        self.free = []             # slots this process may write
        self.moving = (None, None)  # (scale, seconds) of the last moving frame
        self.compiling = False      # its last frame drew an edited material as it was
        self.converging = False     # its last frame's irradiance field had rays to go

    def session(self, preset):
        """The scene's Session, set to `preset`."""
        from ..session import Session
        from ..settings import RenderSettings
        if self._session is None:
            self._session = Session(self.stage, RenderSettings(width=1, height=1,
                                                               preset=preset))
        self._session.configure(preset=preset)
        return self._session

    def set_slots(self, names):
        self.close_slots(unlink=False)
        self.blocks = {name: protocol.attach_block(name) for name in names}
        self.free = list(names)

    def close_slots(self, unlink):
        for block in self.blocks.values():
            protocol.release_block(block, unlink)
        self.blocks, self.free = {}, []

    def session_pending(self) -> int:
        """Programs its session's frames wait for (0 without a session)."""
        return 0 if self._session is None else self._session.programs_pending()

    def close(self, unlink=False):
        if self._session is not None:
            self._session.close()
            self._session = None
        self.close_slots(unlink)


class Host:
    def __init__(self, conn):
        self.conn = conn
        self.scenes = {}
        self.inbox = queue.Queue()
        self.parent_gone = False
        # The context's own warning (rendering on the CPU), taken before the warm-up's
        # renders and handed to Blender with the first frame it asks for.
        self.notices = []

    # --- messages ---------------------------------------------------------------------
    def _read(self):
        try:
            while True:
                self.inbox.put(protocol.loads(self.conn.recv_bytes()))
        except (EOFError, OSError):
            self.inbox.put(None)           # Blender is gone (or closed the pipe)

    def _send(self, kind, **fields):
        self.conn.send_bytes(protocol.dumps(kind, **fields))

    def _take(self, timeout):
        """Every message waiting, after waiting up to `timeout` for the first (None:
        as long as it takes; 0: not at all)."""
        out = []
        try:
            out.append(self.inbox.get(timeout=timeout) if timeout != 0 else
                       self.inbox.get_nowait())
            while True:
                out.append(self.inbox.get_nowait())
        except queue.Empty:
            pass
        return out

    def _handle(self, message) -> bool:
        """Applies one message; False when the host is to stop."""
        if message is None:
            self.parent_gone = True
            return False
        kind, f = message
        if kind == protocol.QUIT:
            return False
        if kind == protocol.WARM:
            self._warm(f["presets"])
            return True
        name = f.get("scene")
        if kind == protocol.DROP:
            scene = self.scenes.pop(name, None)
            if scene is not None:
                scene.close()
            return True
        scene = self.scenes.setdefault(name, Scene())
        now = time.monotonic()
        if kind == protocol.EDIT:
            from ..usd.fragments import apply
            try:
                apply(scene.stage, f["fragment"])
            except Exception as error:
                self._send(protocol.ERROR, scene=name, request=None,
                           message=f"the stage edit failed: {error}")
                return True
            if scene.request is not None and scene.request["progressive"]:
                scene.level, scene.touched = 0, now     # a live view shows edits at once
        elif kind == protocol.RENDER:
            scene.request, scene.level, scene.touched = f, 0, now
        elif kind == protocol.SLOTS:
            scene.set_slots(f["names"])
        elif kind == protocol.RELEASE:
            if f["slot"] in scene.blocks and f["slot"] not in scene.free:
                scene.free.append(f["slot"])
        elif kind == protocol.FORGET:
            scene.request = None
        return True

    # --- rendering --------------------------------------------------------------------
    def _next(self):
        """(scene name or None, seconds until a settled view is due or None)."""
        now, due = time.monotonic(), None
        waiting = [(s.touched, n) for n, s in self.scenes.items()
                   if s.request is not None and s.level == 0]
        if waiting:
            return min(waiting)[1], None
        for name, scene in self.scenes.items():
            # A viewport's field converges over frames, a ray budget each: the next
            # frame at once (one a main loop: edits and new views still come first).
            if scene.request is not None and scene.converging and scene.level == 2:
                return name, None
            # A frame that drew an edited network's old variant: again once the
            # compiler's helper has made the new one (engine/gpu/compiler.py).
            if scene.request is not None and scene.compiling:
                if scene.session_pending() == 0:
                    return name, None
                due = protocol.PROGRAM_POLL_SECONDS
        for name, scene in self.scenes.items():
            if scene.request is not None and scene.level == 1:
                left = scene.touched + protocol.SETTLE_SECONDS - now
                if left <= 0:
                    return name, None
                due = left if due is None else min(due, left)
        return None, due

    def _render(self, name):
        scene = self.scenes[name]
        req = scene.request
        progressive = req["progressive"] and req["preset"] != protocol.INTERACTIVE_PRESET
        final = not progressive or scene.level >= 1
        preset = req["preset"] if final else protocol.INTERACTIVE_PRESET
        passes = [(n, PASSES[n].channels) for n in req["passes"]]
        w, h = req["width"], req["height"]
        scale = 1.0
        if not final and w * h > protocol.INTERACTIVE_MIN_PIXELS:
            scale = protocol.interactive_scale(*scene.moving)
            w, h = max(1, round(w * scale)), max(1, round(h * scale))
        frame_layout, total = protocol.layout(w, h, passes)
        while not scene.free:                   # Blender still reads every slot
            for message in self._take(timeout=None):
                if not self._handle(message):
                    return False
            if self.scenes.get(name) is not scene or scene.request is not req:
                return True                     # dropped, or a newer request
        slot = scene.free.pop(0)
        block = scene.blocks[slot]
        if total > block.size:
            scene.free.append(slot)
            scene.level = 2
            self._send(protocol.ERROR, scene=name, request=req["id"],
                       message=f"a {w}x{h} frame does not fit its {block.size}-byte slot")
            return True
        try:
            session = scene.session(preset)
            session.configure(width=w, height=h, transparent=req["transparent"],
                              passes=frozenset(req["passes"]), camera=req.get("camera"),
                              background_compile=req["progressive"],
                              progressive_field=req["progressive"])
            # The image is read straight into the slot, in Blender's bottom-up rows.
            result = session.render(view_matrix=req.get("view"),
                                    projection_matrix=req.get("projection"),
                                    frame=req.get("frame"), bottom_up=True,
                                    out=protocol.view(block, w, h, 4, frame_layout[0][2]))
        except Exception as error:
            scene.free.append(slot)
            scene.level = 2
            self._send(protocol.ERROR, scene=name, request=req["id"], message=str(error),
                       detail=traceback.format_exc())
            return True
        for pass_name, channels, offset in frame_layout[1:]:
            protocol.view(block, w, h, channels, offset)[:] = result.passes[pass_name][::-1]
        scene.level = 2 if final else 1
        # Not final while an edited material draws its old variant: Blender keeps
        # polling, and the frame with the new one follows.
        scene.compiling = result.stats.get("programs_pending", 0) > 0
        scene.converging = result.stats.get("field_pending", 0) > 0
        if not final:
            scene.touched = time.monotonic()    # settling counts from the frame shown
            # GL work and read-back of the moving frame: what the next one's size is
            # chosen from (the stage read is the same at any size).
            scene.moving = (scale, result.timings["total"] - result.timings.get("load", 0.0))
        self._send(protocol.FRAME, scene=name, request=req["id"], tag=req.get("tag"), slot=slot,
                   width=w, height=h, layout=frame_layout,
                   final=final and not scene.compiling and not scene.converging,
                   preset=preset,
                   stats=result.stats, timings=result.timings, gpu_timings=result.gpu_timings,
                   warnings=self.notices + result.warnings, cryptomatte=result.cryptomatte)
        self.notices = []
        return True

    def _warm(self, presets):
        """Makes the programs of a first frame at these presets now, before Blender
        asks for one (WARM, sent by addon/prestart.py; engine/host/warmup.py). After
        the first preset it stops when a message waits, which then makes what it needs
        itself. A warm-up that fails costs only its time: the first frame then makes
        them."""
        from .warmup import warm
        try:
            seconds = warm(presets, stop=lambda: not self.inbox.empty())
        except Exception as error:
            print(f"lantern host: the warm-up failed: {error}", file=sys.stderr, flush=True)
            return
        print(f"lantern host: warmed up in {seconds:.2f} s", file=sys.stderr, flush=True)

    def run(self) -> int:
        from .. import shutdown
        threading.Thread(target=self._read, name="lantern-host-reader", daemon=True).start()
        try:
            from ..gpu.context import run_gl
            gl, self.notices = run_gl(lambda gl: (
                f"OpenGL {gl.ctx.info['GL_VERSION']}, {gl.renderer}"
                + ("" if gl.device is None else f", EGL device {gl.device}"),
                gl.take_notices()))
        except Exception as error:
            self._send(protocol.FATAL,
                       message=f"the engine could not get an OpenGL context: {error}")
            return 3
        modules = {name: getattr(importlib.util.find_spec(name), "origin", None)
                   for name in ("lantern", "pxr", "numpy", "moderngl", "glcontext")}
        self._send(protocol.READY, pid=os.getpid(), gl=gl, executable=sys.executable,
                   modules=modules)
        try:
            while True:
                name, due = self._next()
                for message in self._take(timeout=0 if name else due):
                    if not self._handle(message):
                        return 0
                name, _ = self._next()
                if name is not None and not self._render(name):
                    return 0
        finally:
            for scene in self.scenes.values():
                scene.close(unlink=self.parent_gone)   # an orphan cleans up after Blender
            shutdown()


def connect(handle: str):
    if sys.platform == "win32":
        return connection.PipeConnection(int(handle))
    return connection.Connection(int(handle))


def main(handle: str) -> int:
    conn = connect(handle)
    try:
        return Host(conn).run()
    finally:
        conn.close()
