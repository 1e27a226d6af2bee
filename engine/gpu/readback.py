"""Getting the image from the GPU into host memory in one copy, off the critical path.

The resolve pass draws the image already in the row order the caller wants (top row
first for numpy, GL's bottom-up for Blender), so nothing flips it on the CPU. Pixels
that are not finite are counted on the GPU (a compute shader on GL 4.3+, an occlusion
query on GL 3.3), so a finite image is never scanned in numpy. Then either:

  blocking     glReadPixels straight into the caller's buffer (the engine host's
               shared-memory block, or a new array), in the format asked for:
               float32 (F12, EXR, compare) or half floats (a viewport: half the bytes);
  queued       glReadPixels into a pixel-buffer object behind a fence; the copy into
               host memory happens when the caller asks for the frame, so frame N+1
               is prepared and drawn while frame N is copied (sequences).

How the pixels cross (MODES, LANTERN_READBACK; docs/gpu.md has the figures):
  direct       blocking reads go straight into the caller's memory; queued ones through
               a pixel buffer, copied out with glGetBufferSubData.
  mapped       (GL 4.4, ARB_buffer_storage) every read goes into a pixel buffer mapped
               once, persistently and coherently, in host memory (client storage); after
               its fence one memcpy takes it into the caller's memory. A driver that
               stages a read into pageable memory through its own pinned buffer then
               copies once, not twice.
Into a caller's reused buffer either mode touches no new memory; without one, the
caller gets a new array (which it owns) and its pages' first touch.

A queued read uses one of SLOTS pixel buffers, counters and fences; the frame graph's
timer queries come in as many sets, so a frame's GPU times are read with its pixels."""
from __future__ import annotations

import ctypes
import os
from dataclasses import dataclass

import numpy as np

from .programs import UNITS, set_uniform
from .stencil import entry_points

# The read-back formats by name (engine/settings.py READBACK_FORMATS): (ModernGL
# dtype, numpy dtype).
FORMATS = {"float32": ("f4", np.float32), "half": ("f2", np.float16)}
SLOTS = 2                       # frames in flight: one drawn while one is copied
# How pixels cross into host memory (module docstring), and the default: on llvmpipe
# (2026-11-27) "direct" measured faster into a reused buffer at every size, and on an
# H100 (1080p float32: 2.2-2.7 ms against 4.4-5.7 mapped; docs/gpu.md).
MODES = ("direct", "mapped")
DEFAULT_MODE = "direct"

GL_SYNC_GPU_COMMANDS_COMPLETE, GL_SYNC_FLUSH_COMMANDS_BIT = 0x9117, 0x1
GL_WAIT_FAILED = 0x911D
GL_PIXEL_PACK_BUFFER, GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 = 0x88EB, 0x8CA8, 0x8CE0
GL_PACK_ALIGNMENT, GL_RGBA, GL_FLOAT, GL_HALF_FLOAT = 0x0D05, 0x1908, 0x1406, 0x140B
GL_MAP_READ_BIT, GL_MAP_PERSISTENT_BIT, GL_MAP_COHERENT_BIT = 0x1, 0x40, 0x80
GL_CLIENT_STORAGE_BIT = 0x200
_MAP = GL_MAP_READ_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT
_GL_TYPES = {"float32": GL_FLOAT, "half": GL_HALF_FLOAT}
_FOREVER = 0xFFFFFFFFFFFFFFFF
_u, _i, _p = ctypes.c_uint, ctypes.c_int, ctypes.c_ssize_t
_SIGS = {
    "glFenceSync": (ctypes.c_void_p, _u, _u),
    "glClientWaitSync": (_u, ctypes.c_void_p, _u, ctypes.c_uint64),
    "glDeleteSync": (None, ctypes.c_void_p),
}
_MAPPED_SIGS = {
    "glGenBuffers": (None, _i, ctypes.POINTER(_u)),
    "glDeleteBuffers": (None, _i, ctypes.POINTER(_u)),
    "glBindBuffer": (None, _u, _u),
    "glBufferStorage": (None, _u, _p, ctypes.c_void_p, _u),
    "glMapBufferRange": (ctypes.c_void_p, _u, _p, _p, _u),
    "glUnmapBuffer": (ctypes.c_ubyte, _u),
    "glBindFramebuffer": (None, _u, _u),
    "glReadBuffer": (None, _u),
    "glPixelStorei": (None, _u, _i),
    "glReadPixels": (None, _i, _i, _i, _i, _u, _u, ctypes.c_void_p),
}


def read_mode(version: int) -> str:
    """The mode this context reads with: LANTERN_READBACK if set (mapped needs GL 4.4),
    else DEFAULT_MODE where the context allows it."""
    asked = os.environ.get("LANTERN_READBACK", "").strip() or DEFAULT_MODE
    if asked not in MODES:
        raise ValueError(f"LANTERN_READBACK must be one of {', '.join(MODES)}, not {asked!r}")
    return asked if asked == "direct" or version >= 440 else "direct"


@dataclass
class ReadbackRequest:
    """How a frame's image reaches host memory."""
    format: str = "float32"      # FORMATS
    top_down: bool = True        # row 0 = the top (numpy); False: GL's bottom-up (Blender)
    out: object = None           # a writable buffer of H * W * 4 values, or None: a new array
    queued: bool = False         # behind a fence, copied by Readback.finish

    def __post_init__(self):
        if self.format not in FORMATS:
            raise ValueError(f"readback format must be one of {', '.join(FORMATS)}, "
                             f"not {self.format!r}")


class MappedPixels:
    """A pixel buffer in host memory, mapped once for reading for its whole life
    (glBufferStorage + glMapBufferRange, persistent and coherent): what the GPU packs
    into it is read through `pointer` once a fence after the pack has signalled."""

    def __init__(self, gl, size: int):
        self._gl, self.size = gl, size
        name = _u()
        gl["glGenBuffers"](1, ctypes.byref(name))
        self.glo = name.value
        gl["glBindBuffer"](GL_PIXEL_PACK_BUFFER, self.glo)
        gl["glBufferStorage"](GL_PIXEL_PACK_BUFFER, size, None, _MAP | GL_CLIENT_STORAGE_BIT)
        self.pointer = gl["glMapBufferRange"](GL_PIXEL_PACK_BUFFER, 0, size, _MAP)
        gl["glBindBuffer"](GL_PIXEL_PACK_BUFFER, 0)
        if not self.pointer:
            self.release()
            raise RuntimeError(f"the GL driver could not map a {size}-byte pixel buffer")

    def pack(self, fbo, size, format: str):
        """glReadPixels of `fbo`'s first colour attachment into this buffer."""
        gl, (w, h) = self._gl, size
        fbo.use()                       # the read framebuffer, as ModernGL knows it
        gl["glReadBuffer"](GL_COLOR_ATTACHMENT0)
        gl["glPixelStorei"](GL_PACK_ALIGNMENT, 1)
        gl["glBindBuffer"](GL_PIXEL_PACK_BUFFER, self.glo)
        gl["glReadPixels"](0, 0, w, h, GL_RGBA, _GL_TYPES[format], None)
        gl["glBindBuffer"](GL_PIXEL_PACK_BUFFER, 0)

    def read_into(self, image: np.ndarray, size: int):
        """The first `size` bytes into `image` (as ModernGL's Buffer.read_into)."""
        ctypes.memmove(image.ctypes.data, self.pointer, size)

    def release(self):
        gl = self._gl
        if self.pointer:
            gl["glBindBuffer"](GL_PIXEL_PACK_BUFFER, self.glo)
            gl["glUnmapBuffer"](GL_PIXEL_PACK_BUFFER)
            gl["glBindBuffer"](GL_PIXEL_PACK_BUFFER, 0)
            self.pointer = None
        gl["glDeleteBuffers"](1, ctypes.byref(_u(self.glo)))


class Slot:
    """The GPU objects of one frame in flight: its non-finite counter and, when
    queued (or mapped), its pixel buffer and fence."""

    def __init__(self, ctx, compute: bool):
        self.counter = ctx.buffer(reserve=4) if compute else ctx.query(samples=True)
        self.pixels = None       # the pixel-buffer object, grown to the largest frame
        self.fence = None
        self.request = None
        self.shape = None


class Readback:
    """Counts the output's non-finite pixels and reads it, blocking or queued, in the
    context's read mode (read_mode)."""

    def __init__(self, ctx, programs, proc, compute: bool, mode: str = "direct"):
        self.ctx, self.programs, self.compute, self.mode = ctx, programs, compute, mode
        self._gl = entry_points(proc, {**_SIGS, **(_MAPPED_SIGS if mode == "mapped" else {})})
        self._slots = [Slot(ctx, compute) for _ in range(SLOTS)]
        self._next = 0

    def slot(self) -> Slot:
        """The next slot; its last frame must have been finished (at most SLOTS - 1
        frames wait while one is drawn)."""
        slot = self._slots[self._next]
        self._next = (self._next + 1) % SLOTS
        if slot.fence is not None:
            raise RuntimeError("a queued frame was never finished")
        return slot

    def counting(self, slot: Slot):
        """Clears the slot's counter and binds it where a compute resolve counts the
        non-finite pixels as it writes them (shaders/resolve.glsl; GL 4.3)."""
        slot.counter.clear()
        slot.counter.bind_to_storage_buffer(0)

    def count(self, slot: Slot, hdr, fbo, size, transparent: bool):
        """Queues the count of `hdr`'s resolved pixels that hold NaN or Inf."""
        w, h = size
        hdr.use(UNITS["hdr"])
        if self.compute:
            slot.counter.clear()
            prog = self.programs.get("nonfinite.comp", compute=True)
            set_uniform(prog, "transparent", bool(transparent))
            slot.counter.bind_to_storage_buffer(0)
            prog.run((w + 7) // 8, (h + 7) // 8)
            self.ctx.memory_barrier()
            return
        prog = self.programs.get("fullscreen.vert", "nonfinite.frag")
        set_uniform(prog, "transparent", bool(transparent))
        fbo.use()
        fbo.color_mask = (False, False, False, False)
        try:
            with slot.counter:
                self.programs.fullscreen(prog)
        finally:
            fbo.color_mask = (True, True, True, True)

    def read(self, slot: Slot, fbo, size, request: ReadbackRequest):
        """The image of `fbo` as (H, W, 4) in the request's format (blocking), or None
        when the read is queued (finish it with `finish(slot)`)."""
        w, h = size
        dtype, np_dtype = FORMATS[request.format]
        slot.request, slot.shape = request, (h, w, 4)
        if request.queued or self.mode == "mapped":
            nbytes = w * h * 4 * np.dtype(np_dtype).itemsize
            if slot.pixels is None or slot.pixels.size < nbytes:
                if slot.pixels is not None:
                    slot.pixels.release()
                slot.pixels = MappedPixels(self._gl, nbytes) if self.mode == "mapped" else \
                    self.ctx.buffer(reserve=nbytes, dynamic=True)
            if self.mode == "mapped":
                slot.pixels.pack(fbo, size, request.format)
            else:
                fbo.read_into(slot.pixels, components=4, dtype=dtype)
            slot.fence = self._gl["glFenceSync"](GL_SYNC_GPU_COMMANDS_COMPLETE, 0)
            return None if request.queued else self.finish(slot)
        image = _target(request.out, slot.shape, np_dtype)
        fbo.read_into(image, components=4, dtype=dtype)
        return image

    def finish(self, slot: Slot) -> np.ndarray:
        """A frame's image from its pixel buffer into host memory (waits for its
        fence)."""
        gl = self._gl
        if slot.fence is not None:
            status = gl["glClientWaitSync"](slot.fence, GL_SYNC_FLUSH_COMMANDS_BIT, _FOREVER)
            gl["glDeleteSync"](slot.fence)
            slot.fence = None
            if status == GL_WAIT_FAILED:
                raise RuntimeError("the GL driver failed waiting for a frame's read-back")
        image = _target(slot.request.out, slot.shape, FORMATS[slot.request.format][1])
        slot.pixels.read_into(image, size=image.nbytes)
        return image

    def nonfinite(self, slot: Slot) -> int:
        """The count queued by `count` (the read before it already waited for it)."""
        if self.compute:
            return int(np.frombuffer(slot.counter.read(), np.uint32)[0])
        return int(slot.counter.samples)

    def release(self):
        for slot in self._slots:
            if slot.fence is not None:
                self._gl["glDeleteSync"](slot.fence)
                slot.fence = None
            if slot.pixels is not None:
                slot.pixels.release()
            if self.compute:
                slot.counter.release()


def _target(out, shape, dtype) -> np.ndarray:
    """The caller's buffer as an (H, W, 4) array, or a new one."""
    if out is None:
        return np.empty(shape, dtype)
    n = int(np.prod(shape))
    image = out if isinstance(out, np.ndarray) else np.frombuffer(out, np.uint8)
    if image.nbytes != n * np.dtype(dtype).itemsize or not image.flags.c_contiguous or \
            not image.flags.writeable:
        raise ValueError(f"the read-back buffer must be a writable, contiguous "
                         f"{shape[1]}x{shape[0]}x4 block of {np.dtype(dtype).name}, not "
                         f"{image.nbytes} bytes")
    return image.reshape(-1).view(dtype).reshape(shape)
