"""Programs made off the render thread: a helper process with a GL context of its own
compiles and links the programs it is handed and stores their binaries in the
persistent program cache (program_binaries.py), from which the render process then
loads them in milliseconds. The viewport uses it when a material's network changes
shape: the old variant is drawn until the new one is stored (engine/gpu/renderer.py
Renderer._drawable).

It serves only where binaries can travel between the two processes: the persistent
cache on, the driver storing binaries, and the helper's GL vendor, renderer and
version the render context's (it says which it has when it starts; else it stops, and
programs are compiled in place as before). The helper starts at the first program it
is handed and lives as long as the render process; it is a plain Python process
started as the engine host is (engine/host/boot.py) running compile_helper.py, talking
over its stdin and stdout."""
from __future__ import annotations

import os
import pickle
import struct
import subprocess
import sys
import threading
import time

_LENGTH = struct.Struct("<I")
# Seconds a program may stay with the helper before the render process makes it itself
# (a helper that hangs must not keep a viewport on the old variant).
PATIENCE = 30.0


def send(stream, message):
    data = pickle.dumps(message)
    stream.write(_LENGTH.pack(len(data)) + data)
    stream.flush()


def receive(stream):
    """The next message, or None at the end of the stream."""
    head = stream.read(_LENGTH.size)
    if len(head) < _LENGTH.size:
        return None
    (length,) = _LENGTH.unpack(head)
    data = stream.read(length)
    return pickle.loads(data) if len(data) == length else None


class BackgroundCompiler:
    """The render process's side: `submit` hands a program to the helper (once per
    key), `pending` counts those not done, `failure` says why one was not made, `wait`
    blocks until none is left."""

    def __init__(self, driver: tuple):
        self.driver = driver            # the render context's (vendor, renderer, version)
        self.broken = None              # why the helper cannot serve, once it cannot
        self._proc = None
        self._lock = threading.Condition()
        self._pending = {}              # key handed over and not done -> when
        self._done = {}                 # key -> None, or why the helper failed it

    def submit(self, key, args) -> bool:
        """Hands `args` (ProgramCache.get's) to the helper; False when it cannot serve."""
        with self._lock:
            if self.broken is not None:
                return False
            if key in self._pending:
                return True
            if self._proc is None and not self._start():
                return False
            self._pending[key] = time.monotonic()
            try:
                send(self._proc.stdin, (key, args))
            except OSError as error:
                self._stop(f"the helper is gone ({error})")
                return False
            return True

    def pending(self) -> int:
        with self._lock:
            self._expire()
            return len(self._pending)

    def failure(self, key):
        """Why the helper could not make `key` (None: made, or not handed over)."""
        with self._lock:
            self._expire()
            return self._done.get(key)

    def _expire(self):
        """(under the lock) Gives up on programs the helper has had for PATIENCE."""
        now = time.monotonic()
        for key, since in list(self._pending.items()):
            if now - since > PATIENCE:
                del self._pending[key]
                self._done[key] = f"not made within {PATIENCE:g} s"
        if not self._pending:
            self._lock.notify_all()

    def wait(self, timeout: float | None = None) -> bool:
        """Blocks until every program handed over is done (or the helper stopped);
        False when `timeout` passed first."""
        with self._lock:
            return self._lock.wait_for(lambda: not self._pending, timeout)

    def _start(self) -> bool:
        package = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        boot = os.path.join(package, "engine", "host", "boot.py")   # runs compile_helper
        try:
            self._proc = subprocess.Popen([sys.executable, "-s", "-P", boot, package, "compiler"],
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        except OSError as error:
            self.broken = f"the helper did not start ({error})"
            return False
        threading.Thread(target=self._read, name="lantern-compiler-reader",
                         daemon=True).start()
        return True

    def _read(self):
        proc = self._proc
        hello = receive(proc.stdout)
        with self._lock:
            if hello is None or tuple(hello) != tuple(self.driver):
                self._stop("the helper's GL is not the render context's: "
                           f"{hello!r} against {self.driver!r}" if hello is not None else
                           "the helper has no GL context, or no program binaries")
                return
        while True:
            message = receive(proc.stdout)
            with self._lock:
                if message is None:
                    self._stop("the helper stopped")
                    return
                key, error = message
                self._pending.pop(key, None)
                self._done[key] = error
                self._lock.notify_all()

    def _stop(self, why):
        """(under the lock) Stops serving: what was pending is compiled in place."""
        self.broken = self.broken or why
        self._pending.clear()
        self._lock.notify_all()
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()

    def close(self):
        with self._lock:
            proc, self._proc = self._proc, None
            self.broken = self.broken or "closed"
            self._pending.clear()
            self._lock.notify_all()
        if proc is not None:
            try:
                proc.stdin.close()
                proc.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                proc.kill()

