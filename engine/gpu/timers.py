"""GPU time per pass from GL timestamp queries (core in GL 3.3), which ModernGL's
32-bit `Query.elapsed` cannot carry past 4.3 s and cannot place between passes.

A set of queries stamps the GPU clock before the first pass and after each pass
(glQueryCounter), so a pass's time is the difference of two stamps and the passes'
times add up to the frame's GPU time, never more. The stamps are read only after the
frame's pixels are in host memory, when the GPU is past them, so reading them never
waits."""
from __future__ import annotations

import ctypes

from .stencil import entry_points

GL_TIMESTAMP, GL_QUERY_RESULT = 0x8E28, 0x8866
_u = ctypes.c_uint
_SIGS = {
    "glGenQueries": (None, ctypes.c_int, ctypes.POINTER(_u)),
    "glDeleteQueries": (None, ctypes.c_int, ctypes.POINTER(_u)),
    "glQueryCounter": (None, _u, _u),
    "glGetQueryObjectui64v": (None, _u, _u, ctypes.POINTER(ctypes.c_uint64)),
}


class PassTimer:
    """Timestamps around the passes of one frame; `sets` frames may be in flight."""

    def __init__(self, proc, sets: int):
        self._gl = entry_points(proc, _SIGS)
        self._sets = [[] for _ in range(sets)]   # query names, grown as passes come
        self._next = 0

    def begin(self) -> "FrameStamps":
        names = self._sets[self._next]
        self._next = (self._next + 1) % len(self._sets)
        stamps = FrameStamps(self, names)
        stamps.stamp("")
        return stamps

    def _query(self, names, i) -> int:
        while len(names) <= i:
            q = _u()
            self._gl["glGenQueries"](1, ctypes.byref(q))
            names.append(q.value)
        return names[i]

    def release(self):
        for names in self._sets:
            for name in names:
                self._gl["glDeleteQueries"](1, ctypes.byref(_u(name)))
            names.clear()


class FrameStamps:
    def __init__(self, timer: PassTimer, names: list):
        self._timer, self._names, self._labels = timer, names, []

    def stamp(self, label: str):
        """The GPU clock once everything issued so far has run; `label` names the pass
        that ends here."""
        query = self._timer._query(self._names, len(self._labels))
        self._timer._gl["glQueryCounter"](query, GL_TIMESTAMP)
        self._labels.append(label)

    def seconds(self) -> dict:
        """{pass: GPU seconds} (waits for the stamps if the GPU is not past them)."""
        gl, value, times = self._timer._gl, ctypes.c_uint64(), []
        for i in range(len(self._labels)):
            gl["glGetQueryObjectui64v"](self._names[i], GL_QUERY_RESULT, ctypes.byref(value))
            times.append(value.value)
        out = {}
        for label, t0, t1 in zip(self._labels[1:], times, times[1:]):
            out[label] = out.get(label, 0.0) + (t1 - t0) * 1e-9
        return out
