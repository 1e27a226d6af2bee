"""Material images as GL textures, kept for the session and uploaded once, in the
file's own precision:

  8-bit         sRGB colour: by default as Cycles filters it. Cycles interpolates the
                stored (encoded) bytes bilinearly at each sample and decodes after, and
                its pixel filter averages many such samples; a 0/1 checker's cell edges
                therefore blend darker than in linear light, also far away (0.477, not
                0.5, on the grazing checker). Here the image goes up as
                GL_SRGB8_ALPHA8 with its own mip chain (cycles_srgb_mips): level 1 is
                the average, over each texel, of Cycles' decoded bilinear lookup of
                level 0, and deeper levels average in linear light. Level 0 the
                shader interpolates in the encoded values itself and decodes
                (material.glsl bilinear, bspline); GL filters the mips.
                RenderSettings.srgb_filtering = "linear" takes EEVEE's (and GL's) way:
                decoded, then filtered, mips averaged in linear light.
                Other 8-bit data: RGBA8, as stored.
  16-bit        RGBA16 (normalized), every level of the file kept; sRGB colour is
                decoded on upload into float32 (Cycles converts such images to linear
                when it loads them).
  half / float  RGBA16F / RGBA32F as the file stores them: nothing is clamped, 4.0
                stays 4.0.
GL filters the mips (trilinear, anisotropic); level 0 of an image filtered as Cycles
filters 8-bit sRGB, or of an interpolation other than Linear, is the shader's, which
reads it through the image's interpolation as Cycles does, and GL's filter of it
starts at level 1 (shaders/material.glsl sample_map, `sampler`).
Wrap modes via samplers (mirror and black are finished in the shader). Reading the files is
engine/textures.py's job; an image that cannot be read (corrupt, truncated, empty,
not an image) becomes a magenta texel and a warning naming the file, here and only
here (`_image`), whatever the reader raises."""
from __future__ import annotations

import numpy as np

from ..color import to_srgb8
from ..textures import is_srgb, linear, map_value, read_rgba, srgb_to_linear
from .pattern import pattern_images

GL_SRGB8_ALPHA8 = 0x8C43
SRGB_FILTERING = ("encoded", "linear")   # Cycles' way (the default), EEVEE's way


def _half(lin: np.ndarray) -> np.ndarray:
    """2x2 box average, sizes halved and floored as GL's levels are."""
    h, w = lin.shape[:2]
    if h > 1:
        lin = 0.5 * (lin[0:h // 2 * 2:2] + lin[1:h // 2 * 2:2])
    if w > 1:
        lin = 0.5 * (lin[:, 0:w // 2 * 2:2] + lin[:, 1:w // 2 * 2:2])
    return lin


def cycles_srgb_mips(img: np.ndarray) -> list:
    """The mip chain (uint8 RGBA, sRGB-encoded, level 0 first) whose level 1 holds,
    per texel, the mean of Cycles' lookup (bilinear of the encoded bytes, then decoded)
    over its 2x2 footprint of level 0 (a 4x4 grid of lookups; at the image's edges
    the edge texels repeat, as GL's own mips never wrap), and whose deeper levels are
    box averages in linear light."""
    levels = [img]
    if img.shape[0] < 2 and img.shape[1] < 2:
        return levels
    e = img.astype(np.float32) / 255.0
    # Lookups at texel offsets +-0.25 from every texel centre: bilinear weights 3/4, 1/4.
    for ax in (0, 1):
        n = e.shape[ax]
        prev = np.take(e, np.r_[0, 0:n - 1], axis=ax)
        nxt = np.take(e, np.r_[1:n, n - 1], axis=ax)
        lo = 0.75 * e + 0.25 * prev                      # a quarter texel back
        hi = 0.75 * e + 0.25 * nxt                       # a quarter texel on
        e = np.stack([lo, hi], axis=ax + 1).reshape(
            e.shape[:ax] + (2 * e.shape[ax],) + e.shape[ax + 1:])
    lin = e.astype(np.float64)
    lin[..., :3] = srgb_to_linear(lin[..., :3])
    # 4x4 lookups per level-1 texel (the 2x upsampled grid, box-averaged twice).
    lin = _half(_half(lin)) if img.shape[0] > 1 and img.shape[1] > 1 else _half(lin)
    h1, w1 = max(img.shape[0] // 2, 1), max(img.shape[1] // 2, 1)
    lin = lin[:h1, :w1]
    levels.append(to_srgb8(lin))
    while lin.shape[0] > 1 or lin.shape[1] > 1:
        lin = _half(lin)
        levels.append(to_srgb8(lin))
    return levels


def data_mips(img: np.ndarray) -> list:
    """The mip chain (uint8 RGBA, level 0 first) of 8-bit data, as llvmpipe's
    glGenerateMipmap makes it from even sizes: each level from the one above, texels
    averaged in pairs across and then in pairs down, each average of two bytes rounded
    half up (its 8-bit filter's weights of 1/2). An odd row or column is left out, as
    in cycles_srgb_mips (GL leaves the filter of odd sizes to the driver)."""
    levels = [img]
    texels = np.ascontiguousarray(img).view(np.uint32)[..., 0]     # RGBA as one word
    while texels.shape[0] > 1 or texels.shape[1] > 1:
        h, w = texels.shape
        if w > 1:
            texels = _byte_means(texels[:, 0:w // 2 * 2:2], texels[:, 1:w // 2 * 2:2])
        if h > 1:
            texels = _byte_means(texels[0:h // 2 * 2:2], texels[1:h // 2 * 2:2])
        levels.append(texels[..., None].view(np.uint8))
    return levels


def _byte_means(a, b):
    """(a + b + 1) // 2 of each of the four bytes of uint32 words, without unpacking
    them (a 4k image's chain in about 0.1 s, not 0.5): a | b less half of a ^ b, its
    bits that cross into the next byte masked off."""
    out = np.bitwise_xor(a, b)
    out &= np.uint32(0xFEFEFEFE)
    out >>= 1
    return np.bitwise_or(a, b) - out


class MaterialTextures:
    def __init__(self, ctx, uploads, anisotropy: float, srgb_filtering: str = "encoded"):
        if srgb_filtering not in SRGB_FILTERING:
            raise ValueError(f"srgb_filtering must be one of {', '.join(SRGB_FILTERING)}, "
                             f"not {srgb_filtering!r}")
        self.ctx, self.uploads = ctx, uploads
        self.anisotropy = anisotropy
        self.srgb_filtering = srgb_filtering
        self._tex = {}
        self._samplers = {}
        self.failed = {}               # path -> warning: images that could not be read
        self._means = {}               # (path, colorspace) -> its linear mean RGBA

    def get(self, path: str, colorspace: str):
        """(texture, cycles_srgb): whether the shader filters it as Cycles filters an
        8-bit sRGB image (gbuffer.frag sample_map)."""
        key = (path, colorspace)
        if key not in self._tex:
            self._tex[key] = self._upload(path, colorspace)
        return self._tex[key]

    def mean(self, ref) -> np.ndarray:
        """A map's mean colour (rgb, linear, its scale and bias applied): what the
        irradiance field takes for a textured surface its rays hit."""
        key = (ref.path, ref.colorspace)
        if key not in self._means:
            self._means[key] = linear(self._image(ref.path), ref.colorspace).reshape(
                -1, 4).mean(axis=0, dtype=np.float64)
        return map_value(ref, self._means[key])

    def _image(self, path):
        """The file's pixels, or a magenta texel when it cannot be read: the one place
        the engine's image-reading errors are caught (engine/image_io raises ImageError,
        a ValueError, naming the file; the file system raises OSError)."""
        try:
            img = read_rgba(path)
            if img.ndim != 3 or img.shape[0] < 1 or img.shape[1] < 1:
                raise ValueError(f"an image of shape {img.shape}")
            return img
        except (ValueError, OSError) as exc:
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            self.failed[path] = f"{path}: cannot be read as an image ({reason}); magenta used"
            return np.array([[[255, 0, 255, 255]]], np.uint8)

    def _upload(self, path, colorspace):
        img = self._image(path)
        img = np.ascontiguousarray(img[::-1])  # GL's t = 0 is the bottom row, as USD st
        h, w = img.shape[:2]
        srgb = is_srgb(img, colorspace)
        decode = img.dtype == np.uint8 and srgb and self.srgb_filtering == "encoded"
        mips = True
        if decode:
            tex = self.uploads.mipmapped_texture(cycles_srgb_mips(img), kind="textures",
                                                 internal_format=GL_SRGB8_ALPHA8)
            mips = False
        elif img.dtype == np.uint8 and not srgb:
            tex = self.uploads.mipmapped_texture(data_mips(img), kind="textures")
            mips = False
        elif img.dtype == np.uint8:     # sRGB filtered as EEVEE does: GL averages decoded
            tex = self.uploads.texture((w, h), 4, img, kind="textures", dtype="f1",
                                       internal_format=GL_SRGB8_ALPHA8)
        elif img.dtype == np.uint16 and not srgb:
            tex = self.uploads.texture((w, h), 4, img, kind="textures", dtype="nu2")
        elif img.dtype == np.float16 and not srgb:
            tex = self.uploads.texture((w, h), 4, img, kind="textures", dtype="f2")
        else:
            tex = self.uploads.texture((w, h), 4, linear(img, colorspace), kind="textures",
                                       dtype="f4")
        if mips:
            tex.build_mipmaps()
        tex.filter = (self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR)
        tex.anisotropy = self.anisotropy
        return tex, decode

    def set_anisotropy(self, anisotropy: float):
        """The preset's anisotropic filtering, on the images and samplers already made
        (material.glsl's own probes take it as u_max_anisotropy)."""
        if anisotropy == self.anisotropy:
            return
        self.anisotropy = anisotropy
        for tex, _ in self._tex.values():
            tex.anisotropy = anisotropy
        for sampler in self._samplers.values():
            sampler.anisotropy = anisotropy

    def sampler(self, wrap_s: str, wrap_t: str, shader_level0: bool = False):
        """Repeat for repeat/mirror (mirror folds st in the shader), clamp-to-edge for
        clamp/black (black masks outside [0,1] in the shader). `shader_level0`: the
        shader reads the image's level 0 itself (an 8-bit sRGB image as Cycles
        interpolates it, or an interpolation other than Linear: material.glsl
        sample_map), so GL's filter starts at level 1 (llvmpipe's anisotropic filter
        would read level 0 wherever the footprint's shorter side is under a texel)."""
        key = (wrap_s in ("repeat", "mirror"), wrap_t in ("repeat", "mirror"), bool(shader_level0))
        if key not in self._samplers:
            sampler = self._samplers[key] = self.ctx.sampler(
                repeat_x=key[0], repeat_y=key[1],
                filter=(self.ctx.LINEAR_MIPMAP_LINEAR, self.ctx.LINEAR),
                anisotropy=self.anisotropy, compare_func="",
                min_lod=1.0 if key[2] else -1000.0)
        return self._samplers[key]

    def prune(self, materials):
        """Releases the images no material uses any more (as a map or in its network)."""
        used = {(ref.path, ref.colorspace) for m in materials
                for ref in [*m.maps.values(), *pattern_images(m)]}
        for key in [k for k in self._tex if k not in used]:
            self._tex.pop(key)[0].release()
            if not any(k[0] == key[0] for k in self._tex):
                self.failed.pop(key[0], None)

    def release(self):
        for tex, _ in self._tex.values():
            tex.release()
        for s in self._samplers.values():
            s.release()
        self._tex.clear()
        self._samplers.clear()
