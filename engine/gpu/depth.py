"""The depth convention on the GL side (engine/view.py states it): 32-bit float depth
everywhere, the clip convention the GL offers, and the far-plane clip distance.
ModernGL makes 24-bit depth textures and knows neither glClipControl nor clip
distances, so these few calls go through the context backend's entry points, as the
stencil calls do (engine/gpu/stencil.py).

  GL 4.5 (clip control)   glClipControl(LOWER_LEFT, ZERO_TO_ONE) while Lantern draws:
                          the projection's z / w is the window depth itself.
  GL 3.3 .. 4.4, macOS    GL's default NDC [-1, 1]: the same reversed depth through
                          2n/d - 1 (precision measured in docs/status.md).
The context's default is restored after every frame (`end`)."""
from __future__ import annotations

import ctypes

from .stencil import entry_points

GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE, GL_ZERO_TO_ONE = 0x8CA1, 0x935E, 0x935F
GL_TEXTURE_2D, GL_DEPTH_COMPONENT, GL_FLOAT = 0x0DE1, 0x1902, 0x1406
GL_DEPTH_COMPONENT32F = 0x8CAC
GL_CLIP_DISTANCE0 = 0x3000
GL_TEXTURE_2D_MULTISAMPLE, GL_SAMPLES, GL_SAMPLE_POSITION = 0x9100, 0x80A9, 0x8E50

_u, _i = ctypes.c_uint, ctypes.c_int
_SIGS = {
    "glBindTexture": (None, _u, _u),
    "glTexImage2D": (None, _u, _i, _i, _i, _i, _i, _u, _u, ctypes.c_void_p),
    "glEnable": (None, _u), "glDisable": (None, _u),
    "glTexImage2DMultisample": (None, _u, _i, _u, _i, _i, ctypes.c_ubyte),
    "glGetIntegerv": (None, _u, ctypes.POINTER(_i)),
    "glGetMultisamplefv": (None, _u, _u, ctypes.POINTER(ctypes.c_float)),
}


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

    def float_depth(self, texture):
        """Re-specifies a ModernGL depth texture (DEPTH_COMPONENT24) as
        DEPTH_COMPONENT32F, same size; its sampling parameters are kept."""
        w, h = texture.size
        self._fn["glBindTexture"](GL_TEXTURE_2D, texture.glo)
        self._fn["glTexImage2D"](GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, w, h, 0,
                                 GL_DEPTH_COMPONENT, GL_FLOAT, None)
        self._fn["glBindTexture"](GL_TEXTURE_2D, 0)
        return texture

    def float_depth_multisample(self, texture):
        """float_depth for a multisampled ModernGL depth texture (its sample count kept,
        and its samples at the same places in every texel)."""
        w, h = texture.size
        self._fn["glBindTexture"](GL_TEXTURE_2D_MULTISAMPLE, texture.glo)
        self._fn["glTexImage2DMultisample"](GL_TEXTURE_2D_MULTISAMPLE, texture.samples,
                                            GL_DEPTH_COMPONENT32F, w, h, 1)
        self._fn["glBindTexture"](GL_TEXTURE_2D_MULTISAMPLE, 0)
        return texture

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
