"""GLSL from shaders/*.glsl: a tiny `#include "file"` preprocessor, variant defines
inserted after `#version`, and compiled programs cached per (context, variant).

Programs live as long as their context (the GL thread's, i.e. the process)."""
from __future__ import annotations

import os
import re

SHADER_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "shaders")
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.M)
_programs: dict = {}


class ShaderError(RuntimeError):
    pass


def load_source(name: str, defines=(), _seen=None) -> str:
    seen = set() if _seen is None else _seen
    with open(os.path.join(SHADER_DIR, name), encoding="utf-8") as f:
        src = f.read()

    def include(m):
        inc = m.group(1)
        if inc in seen:
            return ""
        seen.add(inc)
        return load_source(inc, (), seen)

    src = _INCLUDE.sub(include, src)
    if defines:
        lines = src.split("\n")
        head = [i for i, ln in enumerate(lines) if ln.strip().startswith("#version")]
        at = head[0] + 1 if head else 0
        lines[at:at] = [f"#define {d}" for d in defines]
        src = "\n".join(lines)
    return src


def program(ctx, vert: str, frag: str, defines=()):
    defines = tuple(sorted(defines))
    key = (id(ctx), vert, frag, defines)
    prog = _programs.get(key)
    if prog is None:
        try:
            prog = ctx.program(vertex_shader=load_source(vert, defines),
                               fragment_shader=load_source(frag, defines))
        except Exception as exc:
            raise ShaderError(f"{vert} + {frag} [variant: {', '.join(defines) or 'base'}] "
                              f"failed to compile: {exc}") from exc
        _programs[key] = prog
    return prog


def set_uniform(prog, name, value):
    """Sets a uniform if the compiler kept it; numpy matrices go up column-major."""
    if name not in prog:
        return
    u = prog[name]
    import numpy as np
    if isinstance(value, np.ndarray):
        if value.ndim == 2 and value.shape[0] == value.shape[1]:
            u.write(np.ascontiguousarray(value.T, dtype="f4").tobytes())
            return
        if value.ndim == 2:  # array of vectors
            u.write(np.ascontiguousarray(value, dtype="f4").tobytes())
            return
        value = tuple(float(x) for x in value)
    u.value = value
