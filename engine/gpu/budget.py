"""What a frame needs from the device against what it has, checked before the frame
draws: its render targets' side against the driver's largest, and their bytes against
the memory the driver reports free. A frame that would not fit is refused with one
line giving the size it needs (`TooLarge`), instead of a framebuffer the driver leaves
incomplete halfway through.

Memory is what the driver says: GL_NVX_gpu_memory_info (NVIDIA, and Mesa's radeonsi)
gives the dedicated total and what is free of it; GL_ATI_meminfo (AMD) gives the free
texture memory only. A software rasteriser draws into host memory, so for one the
figures are the host's (MemTotal, MemAvailable). Elsewhere nothing is known and only
the side is checked."""
from __future__ import annotations

import ctypes
from dataclasses import dataclass

_NVX_DEDICATED, _NVX_FREE = 0x9047, 0x9049        # KiB
_ATI_TEXTURE_FREE = 0x87FC                         # KiB: free, largest block, aux, aux block


class TooLarge(ValueError):
    """A frame whose targets would not fit the device: one line with the size."""


@dataclass(frozen=True)
class Memory:
    total: int | None = None    # bytes
    free: int | None = None
    source: str = ""            # where the figures came from; "" when nothing is known

    def stats(self) -> dict:
        return {"gpu_memory_total": self.total, "gpu_memory_free": self.free,
                "gpu_memory_source": self.source}


def memory(ctx, proc, software: bool) -> Memory:
    """The device's memory, as far as its driver says (ctx: a moderngl context, proc:
    the backend's entry-point loader)."""
    extensions = ctx.extensions
    if "GL_NVX_gpu_memory_info" in extensions:
        total, free = _integers(proc, _NVX_DEDICATED, 1)[0], _integers(proc, _NVX_FREE, 1)[0]
        return Memory(total * 1024, free * 1024, "GL_NVX_gpu_memory_info")
    if "GL_ATI_meminfo" in extensions:
        return Memory(None, _integers(proc, _ATI_TEXTURE_FREE, 4)[0] * 1024, "GL_ATI_meminfo")
    if software:
        total, free = _host_memory()
        if free is not None:
            return Memory(total, free, "host memory (software rasteriser)")
    return Memory()


def _integers(proc, name, count):
    get = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))(proc("glGetIntegerv"))
    values = (ctypes.c_int * count)()
    get(name, values)
    return [max(int(v), 0) for v in values]


def _host_memory():
    """(MemTotal, MemAvailable) in bytes from /proc/meminfo; (None, None) elsewhere."""
    fields = {}
    try:
        with open("/proc/meminfo") as f:
            for line in f:                  # both are among the first lines
                key, _, value = line.partition(":")
                fields[key] = int(value.split()[0]) * 1024
                if "MemTotal" in fields and "MemAvailable" in fields:
                    return fields["MemTotal"], fields["MemAvailable"]
    except (OSError, ValueError, IndexError):
        pass
    return None, None


def largest_side(ctx) -> int:
    """The largest render target side this driver takes: a texture, a renderbuffer and a
    viewport must all hold it."""
    info = ctx.info
    return int(min(info.get("GL_MAX_TEXTURE_SIZE", 16384),
                   info.get("GL_MAX_RENDERBUFFER_SIZE", 16384),
                   *info.get("GL_MAX_VIEWPORT_DIMS", (16384, 16384))))


def gib(n: int) -> str:
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.0f} MiB"


def check(output_size, supersample: int, quality: str, largest: int, needed: int,
          available: Memory):
    """TooLarge unless a frame of `output_size` drawn `supersample` times wider and
    taller fits: its side within `largest`, and the `needed` bytes of targets the pool
    would make within the free memory (when the driver says)."""
    w, h = output_size
    k = supersample
    drawn = (w * k, h * k)
    how = f" at {quality} ({k}x{k} supersampling)" if quality else f" with {k}x{k} supersampling"
    what = f"{w}x{h}" + (f"{how} is drawn at {drawn[0]}x{drawn[1]}" if k > 1 else "")
    if max(drawn) > largest:
        raise TooLarge(f"{what}: past this GPU's largest render target ({largest}x{largest}); "
                       "render it smaller or with less supersampling")
    if available.free is not None and needed > available.free:
        raise TooLarge(f"{what}: its render targets need {gib(needed)}, and the GPU has "
                       f"{gib(available.free)} free ({available.source}); render it "
                       "smaller or with less supersampling")
