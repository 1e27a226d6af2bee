"""GL memory: the one place bytes go up, and the pool render targets come from.

Uploads: every byte the engine writes into a GL buffer or texture goes through it and
is counted by kind (mesh, objects, commands, joints, shapes, lights, textures), so
`bytes_uploaded` cannot drift from what really moved (tests/test_boundary.py checks
that nothing else in engine/gpu/ writes GL memory).

TargetPool: textures by (size, format), handed out for a frame's targets and for
shadow maps and taken back, so a session's later frames allocate nothing; and the
framebuffers made of them, cached by attachments."""
from __future__ import annotations

import ctypes
from collections import Counter

import numpy as np

from .stencil import entry_points

KINDS = ("mesh", "objects", "commands", "joints", "shapes", "lights", "textures", "overlays",
         "raytrace", "field")

GL_TEXTURE_2D, GL_TEXTURE0, GL_RGBA, GL_UNSIGNED_BYTE, GL_RGBA8 = \
    0x0DE1, 0x84C0, 0x1908, 0x1401, 0x8058
_u, _i = ctypes.c_uint, ctypes.c_int
_SIGS = {"glActiveTexture": (None, _u), "glBindTexture": (None, _u, _u),
         "glTexImage2D": (None, _u, _i, _i, _i, _i, _i, _u, _u, ctypes.c_void_p)}


class Uploads:
    def __init__(self, ctx, proc=None):
        # proc: the context's entry points (GLContext.proc), for what ModernGL does not
        # wrap: writing a texture's mip levels (mipmapped_texture).
        self.ctx = ctx
        self.bytes = Counter()
        self._gl = entry_points(proc, _SIGS) if proc is not None else None

    def _count(self, kind, n):
        assert kind in KINDS, kind
        self.bytes[kind] += int(n)

    def take(self) -> Counter:
        """Bytes per kind since the last take."""
        out, self.bytes = self.bytes, Counter()
        return out

    def buffer(self, data=None, *, kind: str, reserve: int = 0):
        """A buffer holding `data` (bytes or an array), or `reserve` bytes unwritten."""
        if data is None:
            return self.ctx.buffer(reserve=max(int(reserve), 4))
        data = _bytes(data)
        self._count(kind, len(data))
        return self.ctx.buffer(data)

    def write(self, buffer, data, *, kind: str, offset: int = 0):
        data = _bytes(data)
        self._count(kind, len(data))
        buffer.write(data, offset=offset)

    def copy_into_texture(self, texture, buffer, viewport):
        """A buffer's contents into a texture, inside the GPU: nothing goes up, so
        nothing is counted (the one GPU-side texture write, kept here with the rest)."""
        texture.write(buffer, viewport=viewport)

    def texture(self, size, components, data=None, *, kind: str, dtype="f1", **kw):
        if data is not None:
            data = _bytes(data)
            self._count(kind, len(data))
        return self.ctx.texture(size, components, data, dtype=dtype, **kw)

    def mipmapped_texture(self, levels, *, kind: str, internal_format=GL_RGBA8):
        """An 8-bit RGBA texture whose mip chain is `levels` (uint8 (h, w, 4), level 0
        first, each the size GL gives it: halved, floored, at least 1), every level
        written as given. The driver generates no level: llvmpipe's glGenerateMipmap
        builds a blit shader per format in every new process (0.1-0.15 s of a cold
        render each, which Mesa's shader cache does not keep), and ModernGL can only
        allocate levels by generating them."""
        h, w = levels[0].shape[:2]
        tex = self.texture((w, h), 4, levels[0], kind=kind, dtype="f1",
                           internal_format=internal_format)
        gl = self._gl
        gl["glActiveTexture"](GL_TEXTURE0 + self.ctx.default_texture_unit)  # as ModernGL's writes
        gl["glBindTexture"](GL_TEXTURE_2D, tex.glo)
        for level, data in enumerate(levels[1:], 1):
            data = np.ascontiguousarray(data, np.uint8)
            self._count(kind, data.nbytes)
            gl["glTexImage2D"](GL_TEXTURE_2D, level, internal_format, data.shape[1],
                               data.shape[0], 0, GL_RGBA, GL_UNSIGNED_BYTE, data.ctypes.data)
        return tex

    def write_texture(self, texture, data, *, kind: str, viewport=None, level=0):
        data = _bytes(data)
        self._count(kind, len(data))
        texture.write(data, viewport=viewport, level=level)

    def float_texture(self, texels, *, kind: str):
        """(h, w, 4) float32 -> an RGBA32F texture, nearest, for texelFetch."""
        texels = np.ascontiguousarray(texels, np.float32)
        h, w = texels.shape[:2]
        tex = self.texture((w, h), 4, texels, kind=kind, dtype="f4")
        tex.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        return tex

    def rewrite_float_texture(self, tex, texels, *, kind: str):
        """Writes texels into `tex` in place when the size matches, else replaces it
        (releasing the old one); returns the texture to use."""
        texels = np.ascontiguousarray(texels, np.float32)
        h, w = texels.shape[:2]
        if tex is not None and tex.size == (w, h):
            self.write_texture(tex, texels, kind=kind)
            return tex
        if tex is not None:
            tex.release()
        return self.float_texture(texels, kind=kind)


def _bytes(data) -> bytes:
    if isinstance(data, np.ndarray):
        return np.ascontiguousarray(data).tobytes()
    return bytes(data)


# Target formats. Colour: (components, dtype). Besides these, "depth" is a sampled
# DEPTH_COMPONENT32F texture (G-buffer depth, shadow maps; engine/gpu/depth.py) and
# "depth_stencil" a DEPTH32F_STENCIL8 renderbuffer (light volumes).
COLOR_FORMATS = {"rgba16f": (4, "f2"), "rgba32f": (4, "f4"),
                 "r32f": (1, "f4"), "rg32f": (2, "f4")}   # render passes (AOVs)
# Bytes per texel of every format (depth_stencil: DEPTH32F_STENCIL8 is stored in 8).
# depth_ms4: four samples a texel (passes/gbuffer.py, edge samples).
TEXEL_BYTES = {"depth": 4, "depth_stencil": 8, "depth_ms4": 16,
               **{fmt: n * int(dtype[1]) for fmt, (n, dtype) in COLOR_FORMATS.items()}}


class TargetPool:
    def __init__(self, ctx, stencil):
        self.ctx = ctx
        self.stencil = stencil
        self._free = {}            # (size, format) -> [objects]
        self._out = {}             # id(object) -> (key, object)
        self._fbos = {}            # (ids of attachments) -> framebuffer
        self._wanted = set()       # keys acquired since the last trim

    def acquire(self, size, fmt: str):
        key = (tuple(int(s) for s in size), fmt)
        self._wanted.add(key)
        free = self._free.get(key)
        if free:
            obj = free.pop()
        else:
            obj = self._make(key[0], fmt)
        self._out[id(obj)] = (key, obj)
        return obj

    def release(self, obj):
        key, obj = self._out.pop(id(obj))
        self._free.setdefault(key, []).append(obj)

    def _make(self, size, fmt):
        ctx = self.ctx
        if fmt == "depth_stencil":
            return self.stencil.depth_stencil(size)
        if fmt == "depth":
            tex = ctx.depth_texture(size)        # 32-bit float (depth.FloatDepthLoader)
            tex.compare_func = ""
        elif fmt == "depth_ms4":
            # Read only with texelFetch: a multisampled texture has no sampling state.
            return ctx.depth_texture(size, samples=4)
        else:
            components, dtype = COLOR_FORMATS[fmt]
            tex = ctx.texture(size, components, dtype=dtype)
        tex.filter = (ctx.NEAREST, ctx.NEAREST)
        return tex

    def new_bytes(self, held) -> int:
        """The bytes the pool would allocate to hand out, at once, `held`: {(size,
        format): count} (what it holds free of a key is used first)."""
        total = 0
        for (size, fmt), count in held.items():
            key = (tuple(int(s) for s in size), fmt)
            missing = max(0, count - len(self._free.get(key, ())))
            total += missing * size[0] * size[1] * TEXEL_BYTES[fmt]
        return total

    def framebuffer(self, colors=(), depth=None, depth_stencil=None):
        """The framebuffer of these attachments (made once, kept while they live)."""
        key = tuple(id(a) for a in colors) + (id(depth), id(depth_stencil))
        fbo = self._fbos.get(key)
        if fbo is None:
            fbo = self.ctx.framebuffer(color_attachments=list(colors), depth_attachment=depth)
            if depth_stencil is not None:
                self.stencil.attach(fbo, depth_stencil)
            self._fbos[key] = fbo
        return fbo

    def trim(self):
        """Releases free objects of sizes and formats not asked for since the last
        trim (a viewport that was resized), and their framebuffers."""
        for key in [k for k in self._free if k not in self._wanted]:
            for obj in self._free.pop(key):
                self._drop_framebuffers(id(obj))
                obj.release()
        self._wanted = set()

    def _drop_framebuffers(self, obj_id):
        for key in [k for k in self._fbos if obj_id in k]:
            self._fbos.pop(key).release()

    def held(self) -> int:
        """Objects currently handed out (shadow maps kept across frames)."""
        return len(self._out)

    def release_all(self):
        for fbo in self._fbos.values():
            fbo.release()
        self._fbos.clear()
        objects = [o for objs in self._free.values() for o in objs] + \
            [o for _, o in self._out.values()]
        for obj in objects:
            obj.release()
        self._free.clear()
        self._out.clear()
