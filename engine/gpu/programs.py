"""GLSL programs: shaders/*.glsl with a tiny `#include "file"` preprocessor, variant
defines inserted after `#version` (Filament-style feature bits), compiled once per
context and variant.

Texture units are assigned here and only here (UNITS): a program's sampler uniforms
are pointed at their units when it is compiled, and passes bind a texture to
UNITS[name]. Uniforms are not buffers: set_uniform writes them directly.

Linked programs persist across processes as program binaries
(engine/gpu/program_binaries.py): a program found there is loaded, not compiled."""
from __future__ import annotations

import functools
import logging
import os
import re
import time

import numpy as np

from ...core import cache_folder
from . import program_binaries

log = logging.getLogger(__name__)

SHADER_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), "shaders")
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.M)
_VERSION = re.compile(r"^[^\S\n]*#version[^\n]*", re.M)

# Sampler name -> texture unit, for every sampler of every program. The G-buffer and
# the light pass share units 0-8 (and the smooth normals), materials 9-14 and a pattern
# graph's images (engine/gpu/pattern.py), then the object and light tables, the
# environment, ambient occlusion, post-processing and overlay inputs. A material's maps
# and a network's images stay below 32: llvmpipe reports 32 fragment units, and a
# network's second image on unit 32 read another unit's texture there. The units above
# (area visibility, the exit layer, the shadow tint, the ray tracer's arrays) are read
# right there, as their tests check (test_area_shadows, test_glass, test_shots).
# Programs that never share a draw may share units: the skinning programs (transform
# feedback: no material, no lighting) take the material maps' units, and a network's
# images 5-8 those of programs that draw no material (the environment's prefilter, the
# overlays).
UNITS = {name: unit for unit, name in enumerate((
    "g_base", "g_normal", "g_mat", "g_emit", "g_depth", "latlong", "shadow_cmp", "shadow_raw",
    "hdr",
    "t_diffuse", "t_metallic", "t_roughness", "t_emissive", "t_opacity", "t_normal",
    "u_objects", "u_lights",
    "dfg_lut", "env_specular", "radiance", "ao_tex", "post_src", "t_pattern4",
    "overlay_image", "overlay_atlas",
    "t_pattern0", "t_pattern1", "t_pattern2", "t_pattern3", "g_smooth", "g_sheen",
    "sheen_lut", "area_visibility", "visibility_tex", "shadow_tint"))}
UNITS.update(zip(("u_joint_xforms", "u_shape_offsets", "u_shape_active", "u_influences",
                  "u_deformed", "u_incidence"), range(UNITS["t_diffuse"], UNITS["t_diffuse"] + 6)))
# The light tree's nodes: read by the clustered light passes only, which read no material.
UNITS.update(u_tree=UNITS["t_diffuse"])
UNITS.update(t_pattern5=UNITS["radiance"], t_pattern6=UNITS["overlay_image"],
             t_pattern7=UNITS["overlay_atlas"])
# The Cryptomatte pass samples nothing else (passes/cryptomatte.py).
UNITS.update(crypto_ids=UNITS["g_base"], crypto_names=UNITS["g_normal"])
# Nor do the supersample reduction's edge passes (shaders/edge_samples.glsl).
UNITS.update(edge_depth=UNITS["g_base"], edge_marks=UNITS["g_normal"], separable=UNITS["g_mat"],
             edge_pixels=UNITS["g_emit"])
# No shading program reads post-processing's source: the area lights' table takes its
# unit (shaders/ltc.glsl).
UNITS.update(ltc_lut=UNITS["post_src"])
# Only the area visibility's blur reads visibility_tex, and it reads no shadow map: an
# area light's exit layer takes its unit (passes/shadow_exits.py).
UNITS.update(shadow_exit=UNITS["visibility_tex"])
# The ray tracer's arrays (raytracer.py RtData): read by the light passes (contact
# rays), glass, reflections and the field's trace, which between them sample every
# unit below; after the last.
UNITS.update(rt_data=max(UNITS.values()) + 1)
# The irradiance field (passes/irradiance.py): read by the ambient pass and the field's
# own passes, which sample no material map.
UNITS.update(field_irradiance=UNITS["t_metallic"], field_distance=UNITS["t_roughness"],
             field_probes=UNITS["t_emissive"], field_materials=UNITS["t_opacity"],
             field_rays=UNITS["t_normal"], field_planes=UNITS["t_pattern0"])


class ShaderError(RuntimeError):
    pass


def load_source(name: str, defines=(), _seen=None, generated=()) -> str:
    """`generated`: ((include name, source), ...) standing in for those shader files
    (a material's pattern graph: engine/gpu/pattern.py)."""
    seen = set() if _seen is None else _seen
    made = dict(generated)
    parts = _INCLUDE.split(made[name]) if name in made else _file_parts(name)
    out = []
    for i, part in enumerate(parts):
        if i % 2 == 0:
            out.append(part)
        elif part not in seen:               # an include, once per program
            seen.add(part)
            out.append(load_source(part, (), seen, generated))
    src = "".join(out)
    if defines:                                   # on the lines after #version
        block = "".join(f"#define {d}\n" for d in defines)
        version = _VERSION.search(src)
        if version is None:
            return block + src
        at = version.end()
        src = src[:at] + "\n" + block[:-1] + src[at:]
    return src


def _file_parts(name: str) -> tuple:
    """A shader file's text split at its #include lines: [text, include, text, ...].
    Read once per version of the file (a program's sources are assembled from the same
    few files, at every first use of a variant)."""
    path = os.path.join(SHADER_DIR, name)
    return _parts_of(path, os.stat(path).st_mtime_ns)


@functools.lru_cache(maxsize=256)
def _parts_of(path: str, mtime_ns: int) -> tuple:
    with open(path, encoding="utf-8") as f:
        return tuple(_INCLUDE.split(f.read()))


class ProgramCache:
    """Programs by (shaders, variant), made on first use: loaded from the persistent
    cache when `binaries` (the context's BinaryLoader) has them, else compiled.
    `compiled`, `loaded` and `seconds` count what making them cost, for the stats.
    `ready` and `make_later` let a viewport hand a program to the compiler's helper
    process (compiler.py) instead of compiling it on the render thread."""

    def __init__(self, ctx, binaries=None):
        self.ctx = ctx
        self.binaries = binaries
        self._store = None
        self._driver = None
        self._programs = {}
        self._screen = {}           # program key -> its VAO without buffers
        self.compiled = 0
        self.loaded = 0
        self.seconds = 0.0
        self.background = None      # compiler.BackgroundCompiler, at the first make_later

    @staticmethod
    def _key(vert, frag=None, defines=(), varyings=(), compute=False, generated=(),
             tessellation=()):
        return (vert, frag, tuple(sorted(set(defines))), tuple(varyings), compute,
                tuple(generated), tuple(tessellation))

    def _sources(self, key):
        """(the final sources of key's stages, the name of its stored binary or None when
        the persistent cache is off)."""
        vert, frag, defines, varyings, compute, generated, tessellation = key
        if compute:
            # COMPUTE: the stage, for the includes that differ there (lib.glsl pixel_centre).
            sources = (load_source(vert, defines + ("COMPUTE",), generated=generated), None)
        else:
            sources = (load_source(vert, defines), None if frag is None else
                       load_source(frag, defines, generated=generated))
        stages = tuple(load_source(name, defines) for name in tessellation)
        entry = None
        if self._binaries() is not None:
            entry = program_binaries.entry_key(sources + ("compute",) * compute + stages,
                                               tuple(varyings), self._driver)
        return sources, stages, entry

    def get(self, vert: str, frag: str | None = None, defines=(), varyings=(), compute=False,
            generated=(), tessellation=()):
        """`generated`: ((include name, source), ...) for load_source; part of the key.
        `tessellation`: (control shader, evaluation shader) between `vert` and the rest."""
        key = self._key(vert, frag, defines, varyings, compute, generated, tessellation)
        prog = self._programs.get(key)
        if prog is None:
            prog = self._make(key)
        return prog

    def has(self, *args, **kwargs) -> bool:
        """Whether get(same arguments) returns a program already made."""
        return self._key(*args, **kwargs) in self._programs

    def ready(self, *args, **kwargs) -> bool:
        """Whether get(same arguments) returns at once: made, or its binary stored (a
        load of milliseconds), or the helper gave up on it (then get compiles it, or
        says why it fails)."""
        key = self._key(*args, **kwargs)
        if key in self._programs:
            return True
        _, _, entry = self._sources(key)
        if entry is None:
            return True                     # no cache: nothing can be made elsewhere
        if self._store.read(entry) is not None:
            return True
        helper = self.background
        return helper is not None and (helper.broken is not None or
                                       helper.failure(key) is not None)

    def make_later(self, *args, **kwargs) -> bool:
        """Hands get(same arguments) to the helper process (compiler.py), which stores
        its binary; False when that cannot be done (then get compiles in place)."""
        key = self._key(*args, **kwargs)
        if self._binaries() is None:
            return False
        if self.background is None:
            from .compiler import BackgroundCompiler
            self.background = BackgroundCompiler(self._driver)
        return self.background.submit(key, key)

    def forget(self, prog):
        """Releases a program made by get (the helper keeps none)."""
        self._programs.pop(prog.extra, None)
        vao = self._screen.pop(prog.extra, None)
        if vao is not None:
            vao.release()
        prog.release()

    def _make(self, key):
        vert, frag, defines, varyings, compute, generated, tessellation = key
        t0 = time.perf_counter()
        sources, stages, entry = self._sources(key)
        binaries = self._binaries() if entry is not None else None
        if binaries is not None:
            binaries.expect(entry, self._store.read(entry))
        try:
            if compute:
                prog = self.ctx.compute_shader(sources[0])
            elif stages:
                prog = self.ctx.program(vertex_shader=sources[0], fragment_shader=sources[1],
                                        tess_control_shader=stages[0],
                                        tess_evaluation_shader=stages[1],
                                        varyings=list(varyings))
            elif frag is None:
                prog = self.ctx.program(vertex_shader=sources[0], varyings=list(varyings))
            else:
                prog = self.ctx.program(vertex_shader=sources[0], fragment_shader=sources[1])
        except Exception as exc:
            raise ShaderError(f"{vert} + {frag} [variant: {', '.join(defines) or 'base'}] "
                              f"failed to compile: {exc}") from exc
        finally:
            if binaries is not None:
                binaries.done()
        if binaries is not None and binaries.outcome == "loaded":
            self.loaded += 1
        else:
            self.compiled += 1
        if binaries is not None:
            if binaries.failure:
                log.debug("program cache: %s + %s [%s]: %s; compiled", vert, frag,
                          ", ".join(defines) or "base", binaries.failure)
            if binaries.captured:
                self._store.write(entry, *binaries.captured)
        self.seconds += time.perf_counter() - t0
        for name, unit in UNITS.items():
            if name in prog:
                prog[name].value = unit
        prog.extra = key
        self._programs[key] = prog
        return prog

    def _binaries(self):
        """The context's BinaryLoader when the persistent cache is on and the driver
        stores binaries, else None."""
        if self.binaries is None or cache_folder.disabled() or not self.binaries.active:
            return None
        folder = cache_folder.cache_folder()
        if self._store is None or self._store.folder != folder:
            self._store = program_binaries.ProgramStore(folder)
        if self._driver is None:
            info = self.ctx.info
            self._driver = (info["GL_VENDOR"], info["GL_RENDERER"], info["GL_VERSION"])
        return self.binaries

    def fullscreen(self, prog):
        """Draws one triangle covering the target with `prog` (fullscreen.vert needs
        no vertex buffer)."""
        vao = self._screen.get(prog.extra)
        if vao is None:
            vao = self._screen[prog.extra] = self.ctx.vertex_array(prog, [])
        vao.render(self.ctx.TRIANGLES, vertices=3)

    def __len__(self):
        return len(self._programs)

    def release(self):
        if self.background is not None:
            self.background.close()
            self.background = None
        for vao in self._screen.values():
            vao.release()
        for prog in self._programs.values():
            prog.release()
        self._screen.clear()
        self._programs.clear()


def set_uniform_array(prog, name, values) -> int:
    """An array uniform from `values` (as many as the compiler kept: it may drop an
    array's unread tail); returns the bytes written, 0 when the uniform is gone."""
    if name not in prog:
        return 0
    uniform = prog[name]
    data = np.asarray(values)[:uniform.array_length].tobytes()
    uniform.write(data)
    return len(data)


def set_uniform(prog, name, value):
    """Sets a uniform if the compiler kept it; numpy matrices go up column-major."""
    if name not in prog:
        return
    u = prog[name]
    if isinstance(value, np.ndarray):
        if value.ndim == 2 and value.shape[0] == value.shape[1]:
            u.write(np.ascontiguousarray(value.T, dtype="f4").tobytes())
            return
        if value.ndim >= 2:  # array of vectors or matrices, already laid out
            u.write(np.ascontiguousarray(value, dtype="f4").tobytes())
            return
        value = tuple(float(x) for x in value)
    u.value = value
