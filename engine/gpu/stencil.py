"""Stencil state, which ModernGL does not expose: the few GL calls the light pass
needs, through the context backend's entry points (EGL, GLX, WGL or CGL alike, see
engine/gpu/context.py). ModernGL does not track stencil state, so the two never
disagree. GL 3.3 core calls only.

Light-volume marking (docs/design.md, Light volumes; two-sided stencil, Carmack's
depth-fail):
with the scene depth in the depth buffer, a depth test that passes in front of the
scene (GREATER: depth is reversed, engine/view.py) and no culling, a back face
behind the scene increments and a front face behind the scene decrements, so the
stencil ends non-zero exactly where the scene surface lies inside the volume. The
camera may be inside (front faces clipped away: only the back-face count remains).
The shading draw then tests NOTEQUAL 0 and zeroes what it shades, ready for the
next light."""
from __future__ import annotations

import ctypes

GL_DEPTH32F_STENCIL8, GL_RENDERBUFFER, GL_FRAMEBUFFER = 0x8CAD, 0x8D41, 0x8D40
GL_DEPTH_STENCIL_ATTACHMENT = 0x821A
GL_STENCIL_TEST, GL_STENCIL_BUFFER_BIT, GL_DEPTH_BUFFER_BIT = 0x0B90, 0x400, 0x100
GL_FRONT, GL_BACK, GL_FRONT_AND_BACK = 0x0404, 0x0405, 0x0408
GL_ALWAYS, GL_NOTEQUAL = 0x0207, 0x0205
GL_KEEP, GL_ZERO, GL_INCR_WRAP, GL_DECR_WRAP = 0x1E00, 0, 0x8507, 0x8508
GL_FRAMEBUFFER_COMPLETE = 0x8CD5

_u, _i = ctypes.c_uint, ctypes.c_int
_SIGS = {
    "glGenRenderbuffers": (None, _i, ctypes.POINTER(_u)),
    "glDeleteRenderbuffers": (None, _i, ctypes.POINTER(_u)),
    "glBindRenderbuffer": (None, _u, _u),
    "glRenderbufferStorage": (None, _u, _u, _i, _i),
    "glBindFramebuffer": (None, _u, _u),
    "glFramebufferRenderbuffer": (None, _u, _u, _u, _u),
    "glCheckFramebufferStatus": (_u, _u),
    "glEnable": (None, _u), "glDisable": (None, _u),
    "glStencilFuncSeparate": (None, _u, _u, _i, _u),
    "glStencilOpSeparate": (None, _u, _u, _u, _u),
    "glStencilMask": (None, _u),
    "glClearStencil": (None, _i),
    "glClear": (None, _u),
    "glColorMask": (None, ctypes.c_ubyte, ctypes.c_ubyte, ctypes.c_ubyte, ctypes.c_ubyte),
}
# WGL's entry points are __stdcall on 32-bit Windows; everywhere else C calls.
_FUNCTYPE = getattr(ctypes, "WINFUNCTYPE", ctypes.CFUNCTYPE)


def entry_points(proc, signatures: dict) -> dict:
    """GL functions ModernGL does not wrap, by name, resolved through the context
    backend's `proc(name)`; `signatures` maps a name to (restype, *argtypes)."""
    functions = {}
    for name, (restype, *args) in signatures.items():
        address = proc(name)
        if not address:
            raise RuntimeError(f"GL entry point {name} not found")
        functions[name] = _FUNCTYPE(restype, *args)(address)
    return functions


class Stencil:
    """The stencil calls of one GL context, resolved through `proc(name)`."""

    def __init__(self, proc):
        self._fn = entry_points(proc, _SIGS)

    def depth_stencil(self, size) -> "DepthStencil":
        return DepthStencil(self, size)

    def attach(self, fbo, ds: "DepthStencil"):
        """Attaches a DepthStencil to a ModernGL framebuffer made with colour
        attachments only."""
        gl = self._fn
        gl["glBindFramebuffer"](GL_FRAMEBUFFER, fbo.glo)
        gl["glFramebufferRenderbuffer"](GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT,
                                        GL_RENDERBUFFER, ds.rb.value)
        status = gl["glCheckFramebufferStatus"](GL_FRAMEBUFFER)
        if status != GL_FRAMEBUFFER_COMPLETE:
            raise RuntimeError(f"light-pass framebuffer incomplete (0x{status:x})")

    def clear(self):
        """Zeroes stencil and depth of the bound framebuffer."""
        self._fn["glStencilMask"](0xFF)
        self._fn["glClearStencil"](0)
        self._fn["glClear"](GL_STENCIL_BUFFER_BIT | GL_DEPTH_BUFFER_BIT)

    def color_writes(self, on: bool):
        self._fn["glColorMask"](*(1 if on else 0,) * 4)

    def begin_mark(self):
        """Colour off; depth-fail counting on both faces (see the module note)."""
        gl = self._fn
        gl["glColorMask"](0, 0, 0, 0)
        gl["glEnable"](GL_STENCIL_TEST)
        gl["glStencilMask"](0xFF)
        gl["glStencilFuncSeparate"](GL_FRONT_AND_BACK, GL_ALWAYS, 0, 0xFF)
        gl["glStencilOpSeparate"](GL_BACK, GL_KEEP, GL_INCR_WRAP, GL_KEEP)
        gl["glStencilOpSeparate"](GL_FRONT, GL_KEEP, GL_DECR_WRAP, GL_KEEP)

    def begin_shade(self):
        """Colour on; shade where marked, and zero the mark as it is shaded."""
        gl = self._fn
        gl["glColorMask"](1, 1, 1, 1)
        gl["glStencilFuncSeparate"](GL_FRONT_AND_BACK, GL_NOTEQUAL, 0, 0xFF)
        gl["glStencilOpSeparate"](GL_FRONT_AND_BACK, GL_KEEP, GL_KEEP, GL_ZERO)

    def end(self):
        self._fn["glDisable"](GL_STENCIL_TEST)
        self._fn["glColorMask"](1, 1, 1, 1)


class DepthStencil:
    """A DEPTH32F_STENCIL8 renderbuffer (ModernGL makes no stencil attachments): the
    scene's float depth copied exactly, and the light-volume marks."""

    def __init__(self, stencil: Stencil, size):
        gl = stencil._fn
        self._gl = gl
        self.size = tuple(size)
        self.rb = _u()
        gl["glGenRenderbuffers"](1, ctypes.byref(self.rb))
        gl["glBindRenderbuffer"](GL_RENDERBUFFER, self.rb.value)
        gl["glRenderbufferStorage"](GL_RENDERBUFFER, GL_DEPTH32F_STENCIL8, self.size[0], self.size[1])

    def release(self):
        self._gl["glDeleteRenderbuffers"](1, ctypes.byref(self.rb))
