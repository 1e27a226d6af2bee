"""The engine's own GL context, living on one dedicated worker thread.

ModernGL must never touch Blender's GL context (Blender may run on Vulkan or Metal,
and making another context current on its main thread would break it). So every GL
call, in Blender and in the CLI alike, runs as a job on this thread, which creates a
standalone EGL context lazily on its first job and keeps it for the process."""
from __future__ import annotations

import queue
import threading
from concurrent.futures import Future

_lock = threading.Lock()
_instance = None


class GLThread:
    def __init__(self):
        self._jobs: queue.Queue = queue.Queue()
        self._ctx = None
        self._thread = threading.Thread(target=self._run, name="lantern-gl", daemon=True)
        self._thread.start()

    def _context(self):
        if self._ctx is None:
            self._ctx = _create_context()
        return self._ctx

    def _run(self):
        while True:
            fn, fut = self._jobs.get()
            if fn is None:
                break
            if not fut.set_running_or_notify_cancel():
                continue
            try:
                fut.set_result(fn(self._context()))
            except BaseException as exc:  # handed to the caller, never lost here
                fut.set_exception(exc)
        if self._ctx is not None:
            _forget_programs(self._ctx)
            self._ctx.release()
            self._ctx = None

    def submit(self, fn) -> Future:
        """Queue fn(ctx); the Future carries its result or exception."""
        fut: Future = Future()
        self._jobs.put((fn, fut))
        return fut

    def call(self, fn):
        """Run fn(ctx) on the GL thread and wait for its result (re-raises)."""
        if threading.current_thread() is self._thread:
            return fn(self._context())
        return self.submit(fn).result()

    def stop(self):
        self._jobs.put((None, None))
        self._thread.join()


def _forget_programs(ctx):
    """Compiled programs are cached per context id; a context made after this one is
    released may get the same id, so its entries go with it."""
    from . import shaders, skinning
    for cache in (shaders._programs, skinning._tf_programs):
        for key in [k for k in cache if k[0] == id(ctx)]:
            del cache[key]


def _create_context():
    """A headless context: EGL on Linux (no display needed), else the platform's own
    (CGL on macOS, which stops at GL 4.1; WGL on Windows). GL 3.3 core is the floor."""
    import sys

    import moderngl
    if sys.platform.startswith("linux"):
        try:
            return moderngl.create_context(standalone=True, backend="egl", require=330)
        except Exception as egl_error:  # no EGL: try GLX before giving up
            try:
                return moderngl.create_context(standalone=True, require=330)
            except Exception:
                raise RuntimeError(f"no headless OpenGL 3.3 context: {egl_error}") from egl_error
    return moderngl.create_context(standalone=True, require=330)


def gl_thread() -> GLThread:
    global _instance
    with _lock:
        if _instance is None or not _instance._thread.is_alive():
            _instance = GLThread()
        return _instance


def shutdown():
    """Stops the GL thread after the jobs already queued and releases its context (the
    Blender add-on calls this when it is disabled); the next job starts a new thread."""
    global _instance
    with _lock:
        instance, _instance = _instance, None
    if instance is not None and instance._thread.is_alive():
        instance.stop()


def run_gl(fn):
    """fn(ctx) on the engine's GL thread; returns its result or raises its error."""
    return gl_thread().call(fn)
