"""Which GPU the engine draws on: this machine's EGL devices, the one a process uses,
and what a software rasteriser means.

On Linux the context is made on an EGL device (EGL_EXT_device_enumeration; glcontext's
`device_index`). A process draws on, in this order:
- LANTERN_GPU=N (`lantern render --gpu N` sets it): the device asked for. A GPU is
  then expected, and a device that does not exist is an error naming those that do.
- a worker's slot (`assign_worker`: farm/'s `-j` worker k): the k-th hardware device,
  modulo their number (all devices when none is hardware), so a node's workers spread
  over its GPUs;
- GLCONTEXT_DEVICE_INDEX, glcontext's own variable;
- else the first hardware device, else device 0.
The engine sets GLCONTEXT_DEVICE_INDEX to the device it uses (`use`): glcontext lets
that variable win over the index it is given, and the compiler's helper process
(engine/gpu/compiler.py) inherits it, so its programs are built on the same device.

A context from a software rasteriser (llvmpipe, softpipe, swrast) is an error
(`NoGPU`) when a GPU was expected: LANTERN_GPU given, or LANTERN_REQUIRE_GPU=1.
LANTERN_REQUIRE_GPU=0 says the CPU is expected (the test suite sets it). Otherwise the
process's first render carries one warning (`notice`)."""
from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
import sys
import threading
from dataclasses import dataclass

# GL_RENDERER words of software rasterisers: Mesa's three, Windows' and Apple's.
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "software rasterizer", "gdi generic",
                      "apple software renderer")
_EGL_EXTENSIONS, _EGL_DRM_DEVICE_FILE = 0x3055, 0x3233


class DeviceError(RuntimeError):
    """The device asked for cannot be drawn on: one line."""


class NoSuchDevice(DeviceError):
    pass


class NoGPU(DeviceError):
    pass


@dataclass(frozen=True)
class Device:
    index: int              # EGL device index, as glcontext's device_index takes it
    software: bool          # Mesa's software device (EGL_MESA_device_software)
    node: str | None = None  # its DRM device file, where the driver names one


@functools.cache
def egl_devices() -> tuple:
    """This machine's EGL devices, in EGL's order ((): no EGL, or no device
    enumeration; the context then comes from the platform's default)."""
    if not sys.platform.startswith("linux"):
        return ()
    try:
        egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
        address = egl.eglGetProcAddress
        address.restype, address.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
        query, name = address(b"eglQueryDevicesEXT"), address(b"eglQueryDeviceStringEXT")
    except (OSError, AttributeError):
        return ()
    if not query:
        return ()
    query = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p),
                             ctypes.POINTER(ctypes.c_int))(query)
    text = ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)(name) if name \
        else (lambda device, what: None)
    count = ctypes.c_int(0)
    if not query(0, None, ctypes.byref(count)) or count.value <= 0:
        return ()
    handles = (ctypes.c_void_p * count.value)()
    if not query(count.value, handles, ctypes.byref(count)):
        return ()
    devices = []
    for index, handle in enumerate(handles[:count.value]):
        extensions = (text(handle, _EGL_EXTENSIONS) or b"").decode(errors="replace").split()
        node = text(handle, _EGL_DRM_DEVICE_FILE) if "EGL_EXT_device_drm" in extensions else None
        devices.append(Device(index, "EGL_MESA_device_software" in extensions,
                              node.decode(errors="replace") if node else None))
    return tuple(devices)


def spread(slot: int, devices) -> int:
    """The device of worker `slot`: the hardware devices in turn (all devices when none
    is hardware)."""
    pool = [d.index for d in devices if not d.software] or [d.index for d in devices]
    return pool[slot % len(pool)]


_slot = None


def assign_worker(slot: int):
    """This process is worker `slot` of a node's workers (before its context is made)."""
    global _slot
    _slot = int(slot)


def asked() -> int | None:
    """LANTERN_GPU as a device index (None: not set); a bad value is NoSuchDevice."""
    text = os.environ.get("LANTERN_GPU", "").strip()
    if not text:
        return None
    if not text.isdigit():
        raise NoSuchDevice(f"LANTERN_GPU={text}: not a device number ({listing()})")
    return int(text)


def gpu_expected() -> bool:
    """Whether a software rasteriser is an error: LANTERN_REQUIRE_GPU=1, or a device asked
    for (LANTERN_GPU) unless LANTERN_REQUIRE_GPU=0."""
    required = os.environ.get("LANTERN_REQUIRE_GPU", "").strip()
    if required:
        return required not in ("0", "false", "no")
    return asked() is not None


def cpu_expected() -> bool:
    """LANTERN_REQUIRE_GPU=0: a software rasteriser is what this process expects."""
    return os.environ.get("LANTERN_REQUIRE_GPU", "").strip() in ("0", "false", "no")


def choose() -> int | None:
    """The EGL device index this process draws on (None: no EGL devices)."""
    devices = egl_devices()
    index = asked()
    if index is not None:
        check_exists(index, f"LANTERN_GPU={index}")
        return index
    if not devices:
        return None
    if _slot is not None:
        return spread(_slot, devices)
    inherited = os.environ.get("GLCONTEXT_DEVICE_INDEX", "").strip()
    if inherited.isdigit() and int(inherited) < len(devices):
        return int(inherited)
    return next((d.index for d in devices if not d.software), 0)


def check_exists(index: int, what: str):
    if index >= len(egl_devices()):
        raise NoSuchDevice(f"{what}: no such GPU; {listing()}")


def use(index: int | None):
    """Makes glcontext (here and in the processes this one starts) use `index`."""
    if index is not None:
        os.environ["GLCONTEXT_DEVICE_INDEX"] = str(index)


def is_software(renderer: str) -> bool:
    low = renderer.lower()
    return any(word in low for word in SOFTWARE_RENDERERS)


def short_name(renderer: str) -> str:
    """'llvmpipe' of 'llvmpipe (LLVM 15.0.6, 256 bits)'."""
    return renderer.split(" (")[0].strip() or renderer


_warning_lock = threading.Lock()
_warning_given = False


def check_renderer(renderer: str, index: int | None) -> list:
    """After a context is made: NoGPU when it is a software rasteriser and a GPU was
    expected; else the process's one warning about it (a list of one, once)."""
    global _warning_given
    if not is_software(renderer):
        return []
    if gpu_expected():
        asked_for = asked()
        why = f"--gpu {asked_for} or LANTERN_GPU={asked_for}" if asked_for is not None \
            else "LANTERN_REQUIRE_GPU=1"
        where = "" if index is None else f" on EGL device {index}"
        raise NoGPU(f"rendering on the CPU ({short_name(renderer)}){where}: no GPU device, "
                    f"and {why} asks for one (lantern render --gpu list names the devices)")
    if cpu_expected():
        return []
    with _warning_lock:
        if _warning_given:
            return []
        _warning_given = True
    return [f"rendering on the CPU ({short_name(renderer)}): no GPU device"]


def make_backend(index: int | None, glversion: int):
    """A standalone glcontext EGL backend on device `index` (None: glcontext's default)."""
    import glcontext
    use(index)
    return glcontext.get_backend_by_name("egl")(glversion=glversion, mode="standalone",
                                                 device_index=index or 0)


def describe_all() -> list:
    """[(Device, GL_RENDERER or why no context, total memory in bytes or None)], a
    context made and released on each device in turn (for `--gpu list` and errors)."""
    import moderngl

    from .budget import memory
    out = []
    for device in egl_devices():
        try:
            backend = make_backend(device.index, 330)
            ctx = moderngl.create_context(standalone=True, context=backend, require=330)
        except Exception as error:  # a device EGL lists but cannot make a context on
            out.append((device, f"no context: {error}", None))
            continue
        try:
            renderer = str(ctx.info.get("GL_RENDERER", "?"))
            total = memory(ctx, backend.load, is_software(renderer)).total
        finally:
            ctx.release()
        out.append((device, renderer, total))
    return out


def _device_text(device, renderer, total) -> str:
    software = device.software or is_software(renderer)
    extra = ["software, on the CPU"] if software else []
    if device.node:
        extra.append(device.node)
    if total and not software:
        extra.append(f"{total / 2**30:.1f} GiB")
    return f"{device.index} = {renderer}" + (f" ({', '.join(extra)})" if extra else "")


@functools.cache
def listing() -> str:
    """One line naming this machine's EGL devices."""
    described = describe_all()
    if not described:
        return "this machine lists no EGL devices"
    count = len(described)
    return (f"this machine has {count} EGL device{'s' if count > 1 else ''}: "
            + "; ".join(_device_text(*d) for d in described))


def table() -> list:
    """`--gpu list`: one line per device."""
    return [_device_text(*d) for d in describe_all()]
