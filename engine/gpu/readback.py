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

A queued read uses one of SLOTS pixel buffers, counters and fences; the frame graph's
timer queries come in as many sets, so a frame's GPU times are read with its pixels."""
from __future__ import annotations

import ctypes
from dataclasses import dataclass

import numpy as np

from .programs import UNITS, set_uniform
from .stencil import entry_points

# The read-back formats by name (engine/settings.py READBACK_FORMATS): (ModernGL
# dtype, numpy dtype).
FORMATS = {"float32": ("f4", np.float32), "half": ("f2", np.float16)}
SLOTS = 2                       # frames in flight: one drawn while one is copied

GL_SYNC_GPU_COMMANDS_COMPLETE, GL_SYNC_FLUSH_COMMANDS_BIT = 0x9117, 0x1
GL_WAIT_FAILED = 0x911D
_FOREVER = 0xFFFFFFFFFFFFFFFF
_SIGS = {
    "glFenceSync": (ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint),
    "glClientWaitSync": (ctypes.c_uint, ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint64),
    "glDeleteSync": (None, ctypes.c_void_p),
}


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


class Slot:
    """The GPU objects of one frame in flight: its non-finite counter and, when
    queued, its pixel buffer and fence."""

    def __init__(self, ctx, compute: bool):
        self.counter = ctx.buffer(reserve=4) if compute else ctx.query(samples=True)
        self.pixels = None       # the pixel-buffer object, grown to the largest frame
        self.fence = None
        self.request = None
        self.shape = None


class Readback:
    """Counts the output's non-finite pixels and reads it, blocking or queued."""

    def __init__(self, ctx, programs, proc, compute: bool):
        self.ctx, self.programs, self.compute = ctx, programs, compute
        self._gl = entry_points(proc, _SIGS)
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
        if request.queued:
            nbytes = w * h * 4 * np.dtype(np_dtype).itemsize
            if slot.pixels is None or slot.pixels.size < nbytes:
                if slot.pixels is not None:
                    slot.pixels.release()
                slot.pixels = self.ctx.buffer(reserve=nbytes, dynamic=True)
            fbo.read_into(slot.pixels, components=4, dtype=dtype)
            slot.fence = self._gl["glFenceSync"](GL_SYNC_GPU_COMMANDS_COMPLETE, 0)
            return None
        image = _target(request.out, slot.shape, np_dtype)
        fbo.read_into(image, components=4, dtype=dtype)
        return image

    def finish(self, slot: Slot) -> np.ndarray:
        """A queued frame's image in host memory (waits for its fence)."""
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
