"""The engine's GL context, living on one dedicated worker thread.

ModernGL must never touch Blender's GL context (Blender may run on Vulkan or Metal,
and making another context current on its main thread would break it). So every GL
call, in Blender and in the CLI alike, runs as a job on this thread, which creates a
standalone context lazily on its first job and keeps it for the process.

The context is made on a glcontext backend that Lantern creates itself (EGL on Linux,
no display needed, else GLX; CGL on macOS, which stops at GL 4.1; WGL on Windows) and
hands to ModernGL. It asks for the highest core profile first and steps down
(GL_VERSIONS): Mesa answers any request with its highest version, but NVIDIA's EGL
gives exactly the version asked for, so asking for 3.3 would turn every 4.x path off
on the most common artist GPU. The backend's `load` returns GL entry points on every platform,
for the few calls ModernGL lacks (stencil state, engine/gpu/stencil.py). Compiled
programs belong to this context object and live as long as it does.

On Linux the context is made on the EGL device engine/gpu/devices.py chooses
(LANTERN_GPU, a farm worker's slot, else the first GPU); a software rasteriser is
an error where a GPU was expected, else one warning per process."""
from __future__ import annotations

import os
import queue
import threading
from concurrent.futures import Future
from dataclasses import dataclass

import moderngl

from . import budget, devices
from .depth import FloatDepthLoader
from .program_binaries import BinaryLoader
from .programs import ProgramCache

GL_FLOOR = 330
# Core profiles asked for, best first: 4.6 and 4.5 (glClipControl), 4.3 (multi-draw
# indirect, compute), 4.1 (macOS's last), 3.3 (the floor).
GL_VERSIONS = (460, 450, 430, 410, 330)
# Mesa's software device (llvmpipe) offers 4.5 at most, and 4.6 adds no path of
# Lantern's: asking it for 4.6 first was refused at 20 ms of every new process.
SOFTWARE_GL_MAX = 450


@dataclass(frozen=True)
class Features:
    """The GL paths a session takes. multi_draw: GL 4.3's glMultiDrawElementsIndirect
    with a compute shader gathering the commands; else GL 3.3's one draw per object.
    clip_control: GL 4.5's glClipControl, for reversed float depth written directly
    (engine/gpu/depth.py); else the [-1, 1] fallback. tessellation: subdivision
    surfaces tessellated by the GPU (GL 4.3, beside the multi-draw path); else refined
    on the CPU. compute: the screen passes and skinning as compute shaders (GL 4.3;
    RenderSettings.compute). LANTERN_MAX_GL=33 (or 330) caps a session at the GL 3.3 path, for drivers whose
    newer paths misbehave and for testing that path on any machine."""
    version: int
    multi_draw: bool
    clip_control: bool = False
    tessellation: bool = False
    compute: bool = False

    @staticmethod
    def of(version: int) -> "Features":
        usable = min(version, _version_cap() or version)
        return Features(version=usable, multi_draw=usable >= 430, clip_control=usable >= 450,
                        tessellation=usable >= 430, compute=usable >= 430)


def _version_cap():
    """LANTERN_MAX_GL as a version code: 33 or 330 -> 330, 45 or 450 -> 450."""
    text = os.environ.get("LANTERN_MAX_GL", "").strip()
    if not text:
        return None
    value = int(text)
    return value * 10 if value < 100 else value


class GLContext:
    def __init__(self):
        self.device = devices.choose()      # EGL device index; None: the platform's default
        self.backend, self.requested = _backend(self.device)
        # ModernGL loads its entry points through the program cache's loader, which
        # stands in for compiling and linking (engine/gpu/program_binaries.py).
        self.loader = BinaryLoader(self.backend)
        # And makes its depth textures 32-bit float as it allocates them (depth.py).
        self._depth_loader = FloatDepthLoader(self.loader)
        self.ctx = moderngl.create_context(standalone=True, context=self._depth_loader,
                                           require=GL_FLOOR)
        self.renderer = str(self.ctx.info.get("GL_RENDERER", ""))
        self.software = devices.is_software(self.renderer)
        try:
            self._notices = devices.check_renderer(self.renderer, self.device)
        except devices.NoGPU:
            self.ctx.release()
            raise
        self.programs = ProgramCache(self.ctx, self.loader)
        # A surfaceless context has no default framebuffer, and some draws (transform
        # feedback with rasterisation off) fail without one: keep a 1x1 one bound.
        self.scratch = self.ctx.simple_framebuffer((1, 1))

    @property
    def version(self) -> int:
        return self.ctx.version_code

    def describe(self) -> dict:
        """What the driver gave: renderer, version string, the version asked for."""
        info = self.ctx.info
        return {"gl_renderer": str(info.get("GL_RENDERER", "")),
                "gl_version": str(info.get("GL_VERSION", "")),
                "gl_requested": self.requested,
                "gpu_device": self.device, "gpu_devices": len(devices.egl_devices()),
                "gpu_software": self.software}

    def memory(self) -> budget.Memory:
        """The device's total and free memory, as far as its driver says."""
        return budget.memory(self.ctx, self.proc, self.software)

    def take_notices(self) -> list:
        """What the context has to say once (a software rasteriser's warning)."""
        notices, self._notices = self._notices, []
        return notices

    def proc(self, name: str) -> int:
        """The address of a GL entry point (0 when missing)."""
        return self.backend.load(name)

    def release(self):
        self.programs.release()
        self.scratch.release()
        self.ctx.release()


def _backend(device):
    """(a standalone glcontext backend, the version it was asked for): the highest
    core profile of GL_VERSIONS that the platform creates, on EGL device `device`
    where there is one. LANTERN_MAX_GL caps the paths taken (Features), not the
    request: the process's one context serves sessions with and without the cap."""
    import glcontext
    makers = [lambda version: glcontext.default_backend()(glversion=version,
                                                          mode="standalone")]
    versions = GL_VERSIONS
    if device is not None:     # EGL needs no display; GLX is the fallback
        makers.insert(0, lambda version: devices.make_backend(device, version))
        if devices.asked() is not None:
            makers = makers[:1]    # the device asked for, or an error: never another
        listed = devices.egl_devices()
        if device < len(listed) and listed[device].software:
            versions = tuple(v for v in GL_VERSIONS if v <= SOFTWARE_GL_MAX)
    first_error = None
    for make in makers:
        for version in versions:
            try:
                return make(version), version
            except Exception as error:       # this version or this backend: try the next
                first_error = first_error or error
    raise RuntimeError(f"no headless OpenGL 3.3 context: {first_error}") from first_error


class GLThread:
    def __init__(self):
        self._jobs: queue.Queue = queue.Queue()
        self._gl = None
        self._thread = threading.Thread(target=self._run, name="lantern-gl", daemon=True)
        self._thread.start()

    def _context(self) -> GLContext:
        if self._gl is None:
            self._gl = GLContext()
        return self._gl

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
        if self._gl is not None:
            self._gl.release()
            self._gl = None

    def submit(self, fn) -> Future:
        """Queue fn(gl); the Future carries its result or exception."""
        fut: Future = Future()
        self._jobs.put((fn, fut))
        return fut

    def call(self, fn):
        """Run fn(gl) on the GL thread and wait for its result (re-raises)."""
        if threading.current_thread() is self._thread:
            return fn(self._context())
        return self.submit(fn).result()

    def stop(self):
        self._jobs.put((None, None))
        self._thread.join()


_lock = threading.Lock()
_instance = None


def gl_thread() -> GLThread:
    global _instance
    with _lock:
        if _instance is None or not _instance._thread.is_alive():
            _instance = GLThread()
        return _instance


def run_gl(fn):
    """fn(gl: GLContext) on the engine's GL thread; returns its result or raises."""
    return gl_thread().call(fn)


def shutdown():
    """Stops the GL thread after the jobs already queued and releases its context, with
    the programs it compiled (the Blender add-on calls this when it is disabled; close
    sessions first). The next job starts a new thread."""
    global _instance
    with _lock:
        instance, _instance = _instance, None
    if instance is not None and instance._thread.is_alive():
        instance.stop()
