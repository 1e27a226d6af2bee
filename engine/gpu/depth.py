"""The depth convention on the GL side (engine/view.py states it): 32-bit float depth
everywhere, the clip convention the GL offers, and the far-plane clip distance.
ModernGL makes 24-bit depth textures and knows neither glClipControl nor clip
distances, so these few calls go through the context backend's entry points, as the
stencil calls do (engine/gpu/stencil.py), and the context is made through
`FloatDepthLoader`, which has ModernGL's depth textures made DEPTH_COMPONENT32F.

  GL 4.5 (clip control)   glClipControl(LOWER_LEFT, ZERO_TO_ONE) while Lantern draws:
                          the projection's z / w is the window depth itself.
  GL 3.3 .. 4.4, macOS    GL's default NDC [-1, 1]: the same reversed depth through
                          2n/d - 1 (precision measured in docs/status.md).
The context's default is restored after every frame (`end`)."""
from __future__ import annotations

import ctypes

from .stencil import entry_points

GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE, GL_ZERO_TO_ONE = 0x8CA1, 0x935E, 0x935F
GL_DEPTH_COMPONENT24, GL_DEPTH_COMPONENT32F = 0x81A6, 0x8CAC
GL_CLIP_DISTANCE0 = 0x3000
GL_SAMPLES, GL_SAMPLE_POSITION = 0x80A9, 0x8E50

_u, _i = ctypes.c_uint, ctypes.c_int
_SIGS = {
    "glEnable": (None, _u), "glDisable": (None, _u),
    "glGetIntegerv": (None, _u, ctypes.POINTER(_i)),
    "glGetMultisamplefv": (None, _u, _u, ctypes.POINTER(ctypes.c_float)),
}
# The calls that make a texture's storage, and where their internal format is.
_STORAGE = {
    "glTexImage2D": ((None, _u, _i, _i, _i, _i, _i, _u, _u, ctypes.c_void_p), 2),
    "glTexImage2DMultisample": ((None, _u, _i, _u, _i, _i, ctypes.c_ubyte), 2),
}
_FUNCTYPE = getattr(ctypes, "WINFUNCTYPE", ctypes.CFUNCTYPE)


class FloatDepthLoader:
    """A context backend's loader as ModernGL sees it (`inner`'s entry points), except
    that a texture's storage asked for as DEPTH_COMPONENT24 (ModernGL's one depth
    format) is made DEPTH_COMPONENT32F, and a multisampled one with its samples at the
    same places in every texel. So a depth texture is allocated once, as the engine
    uses it: re-specifying ModernGL's made llvmpipe allocate and clear it twice (a
    cold render's 64 MB of shadow maps). Keep it as long as the context: ModernGL
    calls into its callbacks."""

    def __init__(self, inner):
        self.inner = inner
        self._callbacks = {}

    def load(self, name: str) -> int:
        address = self.inner.load(name)
        if name not in _STORAGE or not address:     # (a missing one stays missing)
            return address
        signature, at = _STORAGE[name]
        real = _FUNCTYPE(*signature)(address)
        multisample = name == "glTexImage2DMultisample"

        def storage(*args):
            if args[at] == GL_DEPTH_COMPONENT24:
                args = args[:at] + (GL_DEPTH_COMPONENT32F,) + args[at + 1:]
                if multisample:
                    args = args[:-1] + (1,)
            real(*args)
        callback = _FUNCTYPE(*signature)(storage)
        self._callbacks[name] = (real, callback)
        return ctypes.cast(callback, ctypes.c_void_p).value

    load_opengl_function = load      # the name ModernGL asks for first

    def __enter__(self):
        return self.inner.__enter__()

    def __exit__(self, *exc):
        return self.inner.__exit__(*exc)

    def release(self):
        self.inner.release()

    def __getattr__(self, name):
        return getattr(self.inner, name)


class DepthConvention:
    def __init__(self, proc, clip_control: bool):
        self.zero_to_one = bool(clip_control)
        names = dict(_SIGS)
        if self.zero_to_one:
            names["glClipControl"] = (None, _u, _u)
        self._fn = entry_points(proc, names)

    def begin(self):
        """A frame starts: the clip convention its projections are made for."""
        if self.zero_to_one:
            self._fn["glClipControl"](GL_LOWER_LEFT, GL_ZERO_TO_ONE)

    def end(self):
        if self.zero_to_one:
            self._fn["glClipControl"](GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE)
        self._fn["glDisable"](GL_CLIP_DISTANCE0)

    def sample_positions(self, framebuffer) -> list:
        """Where the driver puts a multisampled framebuffer's samples in a texel, each
        (x, y) in [0, 1): GL leaves the pattern to the driver (llvmpipe and NVIDIA use
        Direct3D's standard four)."""
        framebuffer.use()
        count = _i(0)
        self._fn["glGetIntegerv"](GL_SAMPLES, ctypes.byref(count))
        out = []
        for s in range(count.value):
            xy = (ctypes.c_float * 2)()
            self._fn["glGetMultisamplefv"](GL_SAMPLE_POSITION, s, xy)
            out.append((float(xy[0]), float(xy[1])))
        return out

    def far_clip(self, on: bool):
        """Clip distance 0 (the camera's far plane, written by the vertex shader)."""
        self._fn["glEnable" if on else "glDisable"](GL_CLIP_DISTANCE0)
