"""The environment's light on the GPU (docs/design.md, Image-based lighting), made once
and kept for the session:

  dfg_lut         the split-sum table (engine/lighting.py dfg_lut, stored in
                  shaders/tables/): every shading program reads its lobes' albedos
                  from it, and the dome's reflections the lobes' moments.
  ltc_lut         the GGX lobe's linearly transformed cosines (engine/ltc.py, stored
                  in shaders/tables/): the area lights' glossy light (shaders/ltc.glsl).
  per dome map    - the lat-long image (float32, mipmapped): the background, exactly
                    as UsdLux maps it;
                  - its irradiance harmonics (order 2, numpy, in the dome's frame):
                    diffuse light, and the smooth part of its reflections (averaged
                    over a lobe exactly from the lobe's moments);
                  - a radiance cube (the map less its harmonics' radiance, resampled,
                    mipmapped) and from it a prefiltered cube: level k holds that
                    rest convolved with the GGX lobe of perceptual roughness r_k,
                    where k = L r_k (2 - r_k) (Filament's mapping: more levels where
                    lobes change fast), made on the GPU by importance sampling
                    (shaders/env_prefilter.frag).
                  Made again only when the map's path changes.
A uniform dome needs none of the per-map work: its harmonics are exact (a constant)
and its reflection is its colour.

Cube faces are rendered through the context backend's glFramebufferTexture2D, which
ModernGL lacks (as engine/gpu/stencil.py does for stencil state)."""
from __future__ import annotations

import ctypes
import math

import numpy as np

from ..lighting import dfg_lut, latlong_sh, velvet_albedo_lut
from ..ltc import ltc_lut
from ..textures import read_image_linear
from .programs import UNITS, set_uniform
from .stencil import entry_points

GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 = 0x8D40, 0x8CE0
GL_TEXTURE_CUBE_MAP_POSITIVE_X = 0x8515
GL_TEXTURE_CUBE_MAP_SEAMLESS = 0x884F
GL_FRAMEBUFFER_COMPLETE = 0x8CD5
_u, _i = ctypes.c_uint, ctypes.c_int
_SIGS = {
    "glFramebufferTexture2D": (None, _u, _u, _u, _u, _i),
    "glCheckFramebufferStatus": (_u, _u),
    "glEnable": (None, _u),
}

SPECULAR_LEVELS = 6          # prefiltered levels: roughness 0, .11, .23, .37, .55, 1
PREFILTER_SAMPLES = 128      # per texel of level 1; filtered lookups keep them noise-free
MAX_PREFILTER_SAMPLES = 2048


def prefilter_samples(level: int) -> int:
    """Samples per texel of a prefiltered level: 4x more each level down (a level has 4x
    fewer texels, so each costs the same), up to MAX_PREFILTER_SAMPLES. Filtered
    lookups read the mip whose texels match a sample's solid angle: with 128 samples a
    rough lobe reads the radiance cube at 2x2 texels a face, which smears a horizon over
    the whole lobe (a white metal of roughness 1 under a two-colour dome: 2.8% off in
    blue; 0.8% with 2048)."""
    return min(PREFILTER_SAMPLES << (2 * (level - 1)), MAX_PREFILTER_SAMPLES)
MIN_FACE, MAX_FACE = 64, 512


def face_size(latlong_width: int) -> int:
    """Cube face texels for a lat-long map: half its width (so the equator keeps its
    texel density), a power of two within [64, 512]."""
    s = 1 << max(0, int(math.ceil(math.log2(max(latlong_width // 2, 1)))))
    return int(min(max(s, MIN_FACE), MAX_FACE))


def level_roughness(level: int, levels: int = SPECULAR_LEVELS) -> float:
    """Perceptual roughness prefiltered into `level` (the inverse of the shader's
    lod = L r (2 - r), L = levels - 1)."""
    return 1.0 - math.sqrt(max(0.0, 1.0 - level / (levels - 1)))


class EnvironmentMap:
    """One dome map on the GPU: lat-long, harmonics, radiance and prefiltered cubes."""

    def __init__(self, path, latlong, sh, radiance, specular, size):
        self.path, self.latlong, self.sh = path, latlong, sh
        self.radiance, self.specular, self.size = radiance, specular, size

    def release(self):
        for tex in (self.latlong, self.radiance, self.specular):
            tex.release()


class Environment:
    def __init__(self, ctx, uploads, programs, proc):
        self.ctx, self.uploads, self.programs = ctx, uploads, programs
        self._fn = entry_points(proc, _SIGS)
        # Cube lookups filter across faces (core since GL 3.2; off by default).
        self._fn["glEnable"](GL_TEXTURE_CUBE_MAP_SEAMLESS)
        self.lut = self._table(dfg_lut())
        self.ltc = self._table(ltc_lut())
        self.map: EnvironmentMap | None = None
        self.failed: dict = {}       # path -> the reason it could not be read
        self.velvet = None           # the velvet sheen's albedo table, made when first drawn

    # --- per map ---------------------------------------------------------------------
    def prepare(self, dome) -> EnvironmentMap | None:
        """The map of `dome` on the GPU, made on first use (None: a uniform dome, or
        a map that could not be read, see `failed`)."""
        path = dome.texture if dome is not None else None
        if path is None or path in self.failed:
            return None
        if self.map is not None and self.map.path == path:
            return self.map
        try:
            img = np.ascontiguousarray(read_image_linear(path, "auto"), np.float32)
        except ValueError as exc:        # ImageError: an unreadable file
            self.failed[path] = str(exc)
            return None
        if self.map is not None:
            self.map.release()
            self.map = None
        self.map = self._build(path, img)
        return self.map

    def _build(self, path, img) -> EnvironmentMap:
        ctx = self.ctx
        h, w = img.shape[:2]
        latlong = self.uploads.texture((w, h), 4, img, kind="textures", dtype="f4")
        latlong.repeat_x, latlong.repeat_y = True, False
        latlong.build_mipmaps()
        latlong.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
        size = face_size(w)
        radiance = ctx.texture_cube((size, size), 4, dtype="f2")
        specular = ctx.texture_cube((size, size), 4, dtype="f2")
        for cube in (radiance, specular):
            cube.build_mipmaps()     # allocates the levels; the passes below fill them
            cube.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
        sh = latlong_sh(img)
        scratch = ctx.texture((size, size), 4, dtype="f2")
        fbo = ctx.framebuffer(color_attachments=[scratch])
        try:
            # Level 0 of both cubes: the map resampled (a mirror reflects it as is).
            prog = self.programs.get("fullscreen.vert", "env_prefilter.frag", ["ENV_FROM_LATLONG"])
            latlong.use(UNITS["latlong"])
            set_uniform(prog, "latlong_lod", max(0.0, math.log2(w / (4.0 * size))))
            set_uniform(prog, "map_sh", np.asarray(sh, "f4"))
            for cube in (radiance, specular):
                self._faces(fbo, prog, cube, 0, size)
            radiance.build_mipmaps()
            # Prefiltered levels, from the radiance cube's mips.
            prog = self.programs.get("fullscreen.vert", "env_prefilter.frag")
            radiance.use(UNITS["radiance"])
            set_uniform(prog, "radiance_size", float(size))
            for level in range(1, SPECULAR_LEVELS):
                set_uniform(prog, "samples", prefilter_samples(level))
                set_uniform(prog, "roughness", level_roughness(level))
                self._faces(fbo, prog, specular, level, max(size >> level, 1))
        finally:
            fbo.release()
            scratch.release()
        return EnvironmentMap(path, latlong, sh, radiance, specular, size)

    def _faces(self, fbo, prog, cube, level, size):
        ctx = self.ctx
        fbo.use()
        ctx.viewport = (0, 0, size, size)
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        set_uniform(prog, "face_size", size)
        gl = self._fn
        for face in range(6):
            gl["glFramebufferTexture2D"](GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0,
                                         GL_TEXTURE_CUBE_MAP_POSITIVE_X + face, cube.glo, level)
            status = gl["glCheckFramebufferStatus"](GL_FRAMEBUFFER)
            if status != GL_FRAMEBUFFER_COMPLETE:
                raise RuntimeError(f"environment cube framebuffer incomplete (0x{status:x})")
            set_uniform(prog, "face", face)
            self.programs.fullscreen(prog)

    # --- shading ---------------------------------------------------------------------
    def bind_tables(self):
        """The tables every shading program reads (lib.glsl, ltc.glsl)."""
        self.lut.use(UNITS["dfg_lut"])
        self.ltc.use(UNITS["ltc_lut"])

    def bind(self, prog, dome, env: EnvironmentMap | None):
        """The dome's light for a shading program (shaders/environment.glsl)."""
        self.bind_tables()
        if dome is None:
            return
        if env is None:
            set_uniform(prog, "dome_sh", np.asarray(dome.sh, "f4"))
            set_uniform(prog, "dome_to_local", np.eye(3))
        else:
            set_uniform(prog, "dome_sh", np.asarray(env.sh * dome.radiance[None, :], "f4"))
            set_uniform(prog, "dome_to_local", np.asarray(dome.rotation, float).T)
            env.latlong.use(UNITS["latlong"])
            env.specular.use(UNITS["env_specular"])
            set_uniform(prog, "env_lod_max", float(SPECULAR_LEVELS - 1))
        set_uniform(prog, "dome_radiance", np.asarray(dome.radiance, float))

    def bind_sheen(self, materials):
        """The velvet sheen's albedo table (shaders/sheen.glsl sheen_lut), made at the
        first frame that draws one of `materials` with a velvet sheen."""
        if not any(m.has_sheen and m.sheen_mode == "ashikhmin" for m in materials):
            return
        if self.velvet is None:
            self.velvet = self._table(velvet_albedo_lut())
        self.velvet.use(UNITS["sheen_lut"])

    def _table(self, table):
        """A (rows, columns, channels) float32 table (engine/lighting.py) as a linearly
        filtered texture, clamped at its edges (shaders/lib.glsl table_uv)."""
        tex = self.uploads.texture(table.shape[1::-1], table.shape[2], table, kind="textures",
                                   dtype="f4")
        tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def release(self):
        if self.velvet is not None:
            self.velvet.release()
        self.lut.release()
        self.ltc.release()
        if self.map is not None:
            self.map.release()
            self.map = None
