"""The persistent program cache: linked GL programs kept on disk as program binaries
(glGetProgramBinary / glProgramBinary, core in GL 4.1, ARB_get_program_binary
before), so that a second process loads what the first compiled instead of
compiling and linking it again.

ModernGL compiles and introspects a program in one C call and has no way to adopt a
program made elsewhere, so the cache sits under it: the context is created through
`BinaryLoader`, which hands ModernGL its own glCompileShader, glGetShaderiv and
glLinkProgram. Around each `ctx.program(...)` the program cache (programs.py) says
what this program is (`expect`): with a stored binary, compiling is deferred and
linking becomes glProgramBinary; without one (or when the driver rejects the stored
one, after an update), the shaders are compiled and linked as usual and the binary
is taken back for the disk. ModernGL's introspection then reads the program as it
would any other. GL entry points come through the context backend's loader, as the
stencil calls do (engine/gpu/stencil.py).

An entry is named by the sha256 of everything that makes its binary: the final
sources (defines already inserted), transform-feedback varyings, and the GL vendor,
renderer and version strings. It is written atomically (temp name, then rename). An
entry that is truncated, damaged, from another key, or rejected by the driver is
ignored and rebuilt, logged only at debug level (`lantern --debug`); a folder that
cannot be written costs the speed-up, never a render. The folder, and the variables
that move it or turn it off, are core/cache_folder.py's."""
from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import struct

from ...core.cache_folder import disabled
from ...core.files import atomic_write_bytes
from .stencil import entry_points

log = logging.getLogger(__name__)

GL_COMPILE_STATUS, GL_LINK_STATUS = 0x8B81, 0x8B82
GL_PROGRAM_BINARY_RETRIEVABLE_HINT, GL_PROGRAM_BINARY_LENGTH = 0x8257, 0x8741
GL_NUM_PROGRAM_BINARY_FORMATS = 0x87FE
GL_TRUE = 1

# An entry: MAGIC, the binary format (u32), the binary's length (u64), the sha256 of
# the key and of the binary, then the binary.
MAGIC = b"LANTERN-PROGRAM-BINARY-1\n"
_HEADER = struct.Struct("<IQ32s32s")

_u, _i = ctypes.c_uint, ctypes.c_int
_IP = ctypes.POINTER(_i)
# ModernGL's own entry points that the cache stands in for.
_HOOKED = {
    "glCompileShader": (None, _u),
    "glGetShaderiv": (None, _u, _u, _IP),
    "glLinkProgram": (None, _u),
}
_SIGS = dict(_HOOKED, **{
    "glGetProgramiv": (None, _u, _u, _IP),
    "glGetIntegerv": (None, _u, _IP),
    "glProgramParameteri": (None, _u, _u, _i),
    "glGetProgramBinary": (None, _u, _i, _IP, ctypes.POINTER(_u), ctypes.c_void_p),
    "glProgramBinary": (None, _u, _u, ctypes.c_void_p, _i),
})
_FUNCTYPE = getattr(ctypes, "WINFUNCTYPE", ctypes.CFUNCTYPE)


def entry_key(sources, varyings, driver) -> bytes:
    """The sha256 naming one program's binary: its final sources, its transform-feedback
    varyings and the driver (GL vendor, renderer, version)."""
    h = hashlib.sha256(MAGIC)
    for part in (*driver, "\0sources", *[s or "" for s in sources], "\0varyings", *varyings):
        h.update(part.encode("utf-8") + b"\0")
    return h.digest()


def encode_entry(key: bytes, fmt: int, binary: bytes) -> bytes:
    return MAGIC + _HEADER.pack(fmt, len(binary), key, hashlib.sha256(binary).digest()) + binary


def decode_entry(key: bytes, data: bytes):
    """(format, binary) of a stored entry, or the reason it cannot be used."""
    head = len(MAGIC) + _HEADER.size
    if len(data) < head or not data.startswith(MAGIC):
        return "not a Lantern program entry (truncated or foreign)"
    fmt, length, stored_key, digest = _HEADER.unpack_from(data, len(MAGIC))
    binary = data[head:]
    if stored_key != key:
        return "made for another program or driver"
    if len(binary) != length:
        return f"truncated ({len(binary)} of {length} bytes)"
    if hashlib.sha256(binary).digest() != digest:
        return "damaged (checksum differs)"
    return fmt, binary


class BinaryLoader:
    """A context backend's loader, as ModernGL sees it: every entry point is the
    backend's except the three the program cache stands in for (see the module
    note). Keep it as long as the context: ModernGL calls into its callbacks."""

    def __init__(self, backend):
        self.backend = backend
        self._gl = None              # the real entry points, resolved on first use
        self._callbacks = {}
        self._expected = None        # (key, stored entry or None) of the program being made
        self._deferred = set()       # shaders whose compiling waits for the link
        self.outcome = None          # "loaded", "compiled" or None, of the last program
        self.captured = None         # (format, binary) of a program just linked
        self.failure = None          # why a stored binary was not used, for the log
        self.formats = 0

    # --- the backend's interface, for ModernGL ------------------------------------------
    def load(self, name: str) -> int:
        if name in _HOOKED and not disabled():
            callback = _FUNCTYPE(*_HOOKED[name])(getattr(self, "_" + name))
            self._callbacks[name] = callback
            return ctypes.cast(callback, ctypes.c_void_p).value
        return self.backend.load(name)

    load_opengl_function = load      # the name ModernGL asks for first

    def __enter__(self):
        return self.backend.__enter__()

    def __exit__(self, *exc):
        return self.backend.__exit__(*exc)

    def release(self):
        self.backend.release()

    def __getattr__(self, name):
        return getattr(self.backend, name)

    # --- the program cache's side ------------------------------------------------------
    @property
    def active(self) -> bool:
        """True when this context can store and load program binaries."""
        if not self._callbacks:
            return False
        if self._gl is None:
            self._gl = entry_points(self.backend.load, _SIGS)
            count = _i(0)
            self._gl["glGetIntegerv"](GL_NUM_PROGRAM_BINARY_FORMATS, ctypes.byref(count))
            self.formats = count.value
        return self.formats > 0

    def expect(self, key: bytes, stored):
        """The next program ModernGL makes is `key`; `stored` is its (format, binary)
        from the disk, or None."""
        self._expected = (key, stored)
        self._deferred.clear()
        self.outcome = self.captured = self.failure = None

    def done(self):
        self._expected = None
        self._deferred.clear()

    # --- the callbacks (ctypes swallows their exceptions, so they raise none) ----------
    def _glCompileShader(self, shader):
        if self._expected is not None and self._expected[1] is not None:
            self._deferred.add(shader)
            return
        self._real("glCompileShader")(shader)

    def _glGetShaderiv(self, shader, pname, out):
        if shader in self._deferred and pname == GL_COMPILE_STATUS:
            out[0] = GL_TRUE
            return
        self._real("glGetShaderiv")(shader, pname, out)

    def _glLinkProgram(self, program):
        expected, self._expected = self._expected, None
        try:
            if expected is not None and expected[1] is not None and self._load(program, *expected[1]):
                self.outcome = "loaded"
                return
            for shader in sorted(self._deferred):
                self._real("glCompileShader")(shader)
            self._deferred.clear()
            if expected is not None:
                self._gl["glProgramParameteri"](program, GL_PROGRAM_BINARY_RETRIEVABLE_HINT,
                                                GL_TRUE)
            self._real("glLinkProgram")(program)
            self.outcome = "compiled"
            if expected is not None and self._status(program, GL_LINK_STATUS):
                self.captured = self._binary(program)
        except Exception as error:  # the link itself has run, or ModernGL reports it
            self.failure = f"{type(error).__name__}: {error}"

    def _real(self, name):
        if self._gl is None:
            self._gl = entry_points(self.backend.load, _SIGS)
        return self._gl[name]

    def _status(self, program, pname) -> int:
        value = _i(0)
        self._gl["glGetProgramiv"](program, pname, ctypes.byref(value))
        return value.value

    def _load(self, program, fmt, binary) -> bool:
        buffer = ctypes.create_string_buffer(binary, len(binary))
        self._gl["glProgramBinary"](program, fmt, buffer, len(binary))
        if self._status(program, GL_LINK_STATUS):
            return True
        self.failure = "the driver rejected the stored binary"
        return False

    def _binary(self, program):
        length = self._status(program, GL_PROGRAM_BINARY_LENGTH)
        if length <= 0:
            return None
        buffer = ctypes.create_string_buffer(length)
        written, fmt = _i(0), _u(0)
        self._gl["glGetProgramBinary"](program, length, ctypes.byref(written),
                                       ctypes.byref(fmt), buffer)
        return (fmt.value, buffer.raw[:written.value]) if written.value > 0 else None


class ProgramStore:
    """Program binaries on disk, one file per key, in `folder`."""

    def __init__(self, folder: str):
        self.folder = folder

    def path(self, key: bytes) -> str:
        return os.path.join(self.folder, key.hex() + ".bin")

    def read(self, key: bytes):
        """(format, binary), or None when there is none usable (logged at debug)."""
        path = self.path(key)
        try:
            with open(path, "rb") as f:
                data = f.read()
        except FileNotFoundError:
            return None
        except OSError as error:
            log.debug("program cache: %s cannot be read (%s); compiling", path, error)
            return None
        entry = decode_entry(key, data)
        if isinstance(entry, str):
            log.debug("program cache: %s is %s; compiling again", path, entry)
            return None
        return entry

    def write(self, key: bytes, fmt: int, binary: bytes) -> bool:
        """Stores an entry atomically; a folder that cannot be written is logged at
        debug level and costs nothing else."""
        try:
            os.makedirs(self.folder, exist_ok=True)
            data = encode_entry(key, fmt, binary)
            atomic_write_bytes(self.path(key), data)
            return True
        except OSError as error:
            log.debug("program cache: %s cannot be written (%s)", self.folder, error)
            return False
