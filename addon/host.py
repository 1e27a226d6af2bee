"""Blender's side of the engine host (engine/host/): the child process, the pipe to
it, and the shared-memory slots frames come back in.

The child is started with Blender's own Python (sys.executable). It finds the add-on
package by its folder (engine/host/boot.py), and the modules Blender's Python may not
find on its own through PYTHONPATH: the folders this process imported pxr from
(Blender's USD) and finds the extension's wheels in (moderngl, glcontext,
mapbox-earcut). numpy is Blender's.

Nothing here waits on a frame on Blender's main thread: messages go out through a
sender thread, frames and errors come in on a reader thread, and the latest frame of
each scene is what gets drawn. F12 waits for its frame on Blender's render thread,
polling Esc. If the child dies or cannot get a GL context, `failure` says why, every
waiter wakes up, and the next `ensure()` (the next redraw or render) starts a new one
(after a GL failure, at most every RESTART_SECONDS). `shutdown()` stops the child and
its threads and unlinks every slot: nothing is left behind. The child's program cache
lives in the extension's own user folder (program_cache_dir), which Blender removes
when the extension is uninstalled.
"""
from __future__ import annotations

import contextlib
import importlib.util
import itertools
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from multiprocessing import Pipe

from ..engine.host import protocol

RESTART_SECONDS = 2.0     # after a child that never got going, wait this long to retry
QUIT_SECONDS = 3.0        # a child that does not stop by then is killed
SENT_KEPT = 10000         # messages remembered (kind, scene, bytes), for tests and bench
WHEELS = ("pxr", "numpy", "moderngl", "glcontext", "mapbox_earcut")
PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class HostError(RuntimeError):
    pass


def program_cache_dir():
    """Where the engine process keeps its program cache (engine/gpu/program_binaries.py)
    when Lantern runs as an extension: the extension's own user folder, which Blender
    deletes with the extension. None otherwise (a legacy add-on, an editable install):
    the engine's default, the user's cache folder."""
    root = (__package__ or "").rpartition(".")[0]      # bl_ext.<repository>.lantern
    if not root.startswith("bl_ext."):
        return None
    import bpy
    return bpy.utils.extension_path_user(root, path="programs")


@dataclass
class Frame:
    scene: str
    request: int
    tag: object
    slot: str
    width: int
    height: int
    layout: list
    final: bool
    preset: str
    stats: dict
    timings: dict
    warnings: list
    number: int = 0           # this scene's frame count when it arrived
    gpu_timings: dict = field(default_factory=dict)   # per pass: GPU seconds
    cryptomatte: dict = field(default_factory=dict)   # {matte: manifest}: RenderResult's


@dataclass
class Channel:
    """One scene's traffic: its slots, its latest frame, its last error."""
    name: str
    key: tuple = ()           # (width, height, passes) the slots are sized for
    blocks: dict = field(default_factory=dict)    # slot name -> SharedMemory (ours)
    retired: dict = field(default_factory=dict)   # slots of an old size still out
    held: str | None = None   # the slot holding `latest`
    latest: Frame | None = None
    error: tuple | None = None  # (request, message)
    requested: int = 0        # the last request's id
    frames: int = 0
    fresh: bool = False       # a frame arrived since `take_fresh`
    event: threading.Event = field(default_factory=threading.Event)


def module_dirs(names=WHEELS) -> list:
    """The sys.path folders this process finds these top-level modules in (Blender's
    own for pxr and numpy, the extension's wheel folder for the others)."""
    out = []
    for name in names:
        spec = importlib.util.find_spec(name)
        if spec is None or not spec.origin:
            continue
        root = os.path.dirname(spec.origin)
        folder = os.path.dirname(root) if spec.submodule_search_locations else root
        if folder not in out:
            out.append(folder)
    return out


def describe_exit(status) -> str:
    if status is None:
        return "it stopped answering"
    if status < 0:
        try:
            return f"killed by {signal.Signals(-status).name}"
        except ValueError:
            return f"killed by signal {-status}"
    return f"exit status {status}"


class Host:
    def __init__(self):
        self._lock = threading.RLock()
        self._ids = itertools.count(1)
        self._blocks = itertools.count()
        self.proc = None
        self.conn = None
        self.generation = 0        # the child's: unique in this Blender process (_children)
        self.channels = {}
        self.failure = None        # why the last child stopped, or could not start
        self.info = None           # the child's READY fields (pid, GL)
        self.sent = deque(maxlen=SENT_KEPT)  # (kind, scene, bytes) of the last messages
        self.messages = 0          # messages sent since this Host was made
        self.log = deque(maxlen=40)  # the child's stderr, last lines
        self._outbox = None
        self._threads = []
        self._started = 0.0
        self._ready = threading.Event()

    # --- the process ------------------------------------------------------------------
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None and self.failure is None

    def why(self):
        """Why no child runs (None while one does): the reader's account, or the exit
        status of a child that died before the reader saw it go."""
        if self.running():
            return None
        if self.failure is not None:
            return self.failure
        if self.proc is not None and self.proc.poll() is not None:
            return f"the engine process stopped ({describe_exit(self.proc.returncode)})"
        return "the engine process is not running"

    def ensure(self) -> bool:
        """Starts the child if none runs (a new generation: every scene must be sent
        again); False while a failed start is too recent to retry."""
        with self._lock:
            if self.running():
                return True
            if self.proc is not None and self.failure is not None and \
                    not self._ready.is_set() and \
                    time.monotonic() - self._started < RESTART_SECONDS:
                return False
            body = self._detach(quit_first=False)
        _bury(*body)
        with self._lock:
            if not self.running():
                self._start()
            return True

    def _start(self):
        parent_end, child_end = Pipe(duplex=True)
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(
            module_dirs() + [d for d in env.get("PYTHONPATH", "").split(os.pathsep) if d])
        cache = program_cache_dir()
        if cache is not None and not env.get("LANTERN_PROGRAM_CACHE_DIR"):   # the user's wins
            env["LANTERN_PROGRAM_CACHE_DIR"] = cache
        command = [sys.executable, "-s", "-P",
                   os.path.join(PACKAGE_DIR, "engine", "host", "boot.py"), PACKAGE_DIR]
        handle = child_end.fileno()
        kwargs = {}
        if sys.platform == "win32":
            os.set_handle_inheritable(handle, True)
            info = subprocess.STARTUPINFO()
            info.lpAttributeList = {"handle_list": [handle]}
            kwargs["startupinfo"] = info
        else:
            kwargs["pass_fds"] = (handle,)
        self.proc = subprocess.Popen(command + [str(handle)], env=env, stdin=subprocess.DEVNULL,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     close_fds=True, **kwargs)
        child_end.close()
        self.conn = parent_end
        # Unique across Host objects too: a Host made after a shutdown must not reuse
        # an earlier child's number (prestart.py warms up each new child once by it).
        self.generation = next(_children)
        self.failure, self.info = None, None
        self._ready.clear()
        self._started = time.monotonic()
        self._outbox = queue.Queue()
        self._threads = [threading.Thread(target=fn, args=args, name=name, daemon=True)
                         for fn, args, name in (
                             (self._read, (self.conn, self.proc), "lantern-host-read"),
                             (self._write, (self._outbox, self.conn), "lantern-host-write"),
                             (self._drain, (self.proc.stderr,), "lantern-host-log"))]
        for thread in self._threads:
            thread.start()

    def _drain(self, stream):
        for line in stream:
            self.log.append(line.decode(errors="replace").rstrip())

    def _write(self, outbox, conn):
        while True:
            data = outbox.get()
            if data is None:
                return
            try:
                conn.send_bytes(data)
            except (OSError, ValueError):
                return

    def _read(self, conn, proc):
        try:
            while True:
                kind, fields = protocol.loads(conn.recv_bytes())
                self._receive(kind, fields)
        except (EOFError, OSError, ValueError):
            pass
        try:
            status = proc.wait(timeout=QUIT_SECONDS)
        except subprocess.TimeoutExpired:
            status = None
        with self._lock:
            if self.proc is proc and self.failure is None:
                self.failure = f"the engine process stopped ({describe_exit(status)})"
            for channel in self.channels.values():
                channel.event.set()

    def _receive(self, kind, f):
        with self._lock:
            if kind == protocol.READY:
                self.info = f
                self._ready.set()
                return
            if kind == protocol.FATAL:
                self.failure = f["message"]
                return
            channel = self.channels.get(f["scene"])
            if channel is None:
                return
            if kind == protocol.ERROR:
                channel.error = (f["request"], f["message"])
                channel.event.set()
                return
            frame = Frame(**{k: f[k] for k in Frame.__dataclass_fields__ if k in f})
            if frame.slot not in channel.blocks:
                return                             # a slot of an older size
            old = channel.held
            if old is not None and old != frame.slot:
                if old in channel.retired:         # shown until now, of an older size
                    protocol.release_block(channel.retired.pop(old), unlink=True)
                else:
                    self._post(protocol.RELEASE, scene=channel.name, slot=old)
            channel.frames += 1
            frame.number = channel.frames
            channel.held, channel.latest, channel.fresh = frame.slot, frame, True
            channel.event.set()

    def _post(self, kind, **fields) -> int:
        data = protocol.dumps(kind, **fields)
        self.sent.append((kind, fields.get("scene"), len(data)))
        self.messages += 1
        self._outbox.put(data)
        return len(data)

    def sent_since(self, mark) -> list:
        """(kind, scene, bytes) of the messages sent since self.messages was `mark`."""
        count = self.messages - mark
        return list(self.sent)[-count:] if count > 0 else []

    def send(self, kind, **fields) -> int:
        """Queues a message for the child; returns its size in bytes."""
        with self._lock:
            if not self.running():
                raise HostError(self.why())
            return self._post(kind, **fields)

    # --- scenes -----------------------------------------------------------------------
    def channel(self, name) -> Channel:
        with self._lock:
            if name not in self.channels:
                self.channels[name] = Channel(name)
            return self.channels[name]

    def edit(self, scene, fragment) -> int:
        return self.send(protocol.EDIT, scene=scene, fragment=fragment)

    def render(self, scene, *, width, height, preset, passes=(), transparent=False,
               view=None, projection=None, camera=None, frame=None, progressive=False,
               tag=None) -> int:
        """Asks for a frame of `scene`; returns the request's id. The frame arrives
        on its own (`frame()`, `wait()`)."""
        from ..core.passes import PASSES
        with self._lock:
            channel = self.channel(scene)
            key = (int(width), int(height), tuple(passes))
            if key != channel.key:
                self._resize(channel, key, [(n, PASSES[n].channels) for n in passes])
            channel.requested = request = next(self._ids)
            channel.error = None
            channel.event.clear()
            self.send(protocol.RENDER, scene=scene, id=request, width=int(width),
                      height=int(height), preset=preset, passes=list(passes),
                      transparent=bool(transparent), view=view, projection=projection,
                      camera=camera, frame=frame, progressive=bool(progressive), tag=tag)
            return request

    def _resize(self, channel, key, passes):
        """New slots for frames of another size or other passes."""
        _, size = protocol.layout(key[0], key[1], passes)
        for name, block in channel.blocks.items():
            if name == channel.held:
                channel.retired[name] = block      # shown until a new frame arrives
            else:                                  # the child closes its mapping on SLOTS
                protocol.release_block(block, unlink=True)
        names = [f"lantern_{os.getpid()}_{next(self._blocks)}"
                 for _ in range(protocol.SLOTS_PER_TARGET)]
        channel.blocks = {name: protocol.create_block(name, max(size, 1)) for name in names}
        channel.key = key
        self.send(protocol.SLOTS, scene=channel.name, names=names)

    @contextlib.contextmanager
    def frame(self, scene):
        """(Frame, {pass name: float32 (H, W, C) view, bottom row first}) of the
        scene's latest frame, or None; the slot stays ours inside the block."""
        with self._lock:
            channel = self.channels.get(scene)
            frame = channel.latest if channel else None
            if frame is None:
                yield None
                return
            block = channel.blocks.get(frame.slot) or channel.retired.get(frame.slot)
            views = {name: protocol.view(block, frame.width, frame.height, c, offset)
                     for name, c, offset in frame.layout}
            try:
                yield frame, views
            finally:
                del views

    def take_fresh(self, scene) -> bool:
        """Whether a frame arrived since the last call."""
        with self._lock:
            channel = self.channels.get(scene)
            fresh = bool(channel and channel.fresh)
            if fresh:
                channel.fresh = False
            return fresh

    def wait(self, scene, request, test_break=lambda: False, poll=0.02):
        """Blocks (on a render thread, never Blender's main one) until frame `request`
        of `scene` arrives; None when test_break() turns true first (the request is
        forgotten). Raises HostError when it failed or the engine stopped."""
        channel = self.channel(scene)
        while True:
            with self._lock:
                if channel.error is not None and channel.error[0] in (request, None):
                    raise HostError(channel.error[1])
                if channel.latest is not None and channel.latest.request == request:
                    return channel.latest
                if not self.running():
                    raise HostError(self.why())
                channel.event.clear()
            if test_break():
                with contextlib.suppress(HostError):
                    self.send(protocol.FORGET, scene=scene)
                return None
            channel.event.wait(poll)

    def drop(self, scene):
        """Forgets a scene here and in the child (its stage, Sessions and slots)."""
        with self._lock:
            channel = self.channels.pop(scene, None)
            if self.running():
                self._post(protocol.DROP, scene=scene)
            if channel is not None:
                self._close_channel(channel)

    def _close_channel(self, channel):
        for block in list(channel.blocks.values()) + list(channel.retired.values()):
            protocol.release_block(block, unlink=True)
        channel.blocks, channel.retired, channel.latest, channel.held = {}, {}, None, None
        channel.event.set()

    # --- stopping ---------------------------------------------------------------------
    def _detach(self, quit_first):
        """Takes the child, its threads and every slot out of this Host (under the
        lock); `_bury` then stops them (without it: the reader takes the lock)."""
        proc, conn, outbox, threads = self.proc, self.conn, self._outbox, self._threads
        if proc is not None and quit_first and proc.poll() is None and outbox is not None:
            self._post(protocol.QUIT)
        for channel in self.channels.values():
            self._close_channel(channel)
        self.channels = {}
        self.proc = self.conn = self._outbox = None
        self._threads = []
        return proc, conn, outbox, threads, quit_first

    def shutdown(self):
        with self._lock:
            body = self._detach(quit_first=True)
            self.failure = None
        _bury(*body)

    def kill(self):
        """Kills the child at once (tests: an engine process that dies mid-render)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()


def _bury(proc, conn, outbox, threads, quit_first):
    """Stops a detached child: asked to quit, then killed if it does not; its pipe
    closed and its threads joined."""
    if proc is None:
        return
    if outbox is not None:
        outbox.put(None)                       # the sender ends after the QUIT
    try:
        proc.wait(timeout=QUIT_SECONDS if quit_first else 0.5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    conn.close()
    for thread in threads:
        thread.join()
    proc.stderr.close()


_host = None
_host_lock = threading.Lock()


_children = itertools.count(1)     # generations of the children this process starts


def get() -> Host:
    global _host
    with _host_lock:
        if _host is None:
            _host = Host()
        return _host


def shutdown():
    """Add-on disable: no process, thread or shared memory left."""
    global _host
    with _host_lock:
        host, _host = _host, None
    if host is not None:
        host.shutdown()
