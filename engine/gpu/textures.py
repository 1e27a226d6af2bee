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

import functools

import numpy as np

from ..color import to_srgb8
from ..textures import is_srgb, linear, linear_mean, map_value, read_rgba, srgb_to_linear
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


# Level-1 texels that cycles_srgb_mips makes at a time, in bands of whole rows: their
# level-0 texels' lookups are decoded into float64s, so a band stays within the CPU's
# caches (a 1k image's chain 250 -> 110 ms against bands 4x as large; the whole 2x
# grid of lookups at once took 660 MB for a 1k image).
BAND_TEXELS = 16384
# A lookup is (9a + 3b + 3c + d) / 16 of four bytes (bilinear weights 3/4 and 1/4 on
# both axes): an integer over LOOKUP_SCALE, decoded by a table of its 4,081 values.
LOOKUP_SCALE = 16 * 255


@functools.lru_cache(maxsize=None)
def _decoded_lookups() -> np.ndarray:
    """(LOOKUP_SCALE + 1,) float64: the sRGB decode of every lookup."""
    return srgb_to_linear(np.arange(LOOKUP_SCALE + 1) / LOOKUP_SCALE)


def cycles_srgb_mips(img: np.ndarray) -> list:
    """The mip chain (uint8 RGBA, sRGB-encoded, level 0 first) whose level 1 holds,
    per texel, the mean of Cycles' lookup (bilinear of the encoded bytes, then decoded)
    over its 2x2 footprint of level 0 (a 4x4 grid of lookups; at the image's edges
    the edge texels repeat, as GL's own mips never wrap; an image one texel tall or
    wide has 2 lookups across that side), and whose deeper levels are box averages in
    linear light. Lookups are made in integers and decoded by a table, in bands of
    rows."""
    levels = [img]
    h, w = img.shape[:2]
    if h < 2 and w < 2:
        return levels
    h1, w1 = max(h // 2, 1), max(w // 2, 1)
    lin = np.empty((h1, w1, 4))
    band = max(BAND_TEXELS // w1, 1)
    for r0 in range(0, h1, band):
        r1 = min(r0 + band, h1)
        lin[r0:r1] = _level1_band(img, r0, r1, w1)
    levels.append(to_srgb8(lin))
    while lin.shape[0] > 1 or lin.shape[1] > 1:
        lin = _half(lin)
        levels.append(to_srgb8(lin))
    return levels


def _level1_band(img, r0, r1, w1) -> np.ndarray:
    """Rows r0..r1 of cycles_srgb_mips' level 1 (linear, float64, RGBA last)."""
    h, w = img.shape[:2]
    ry, rx = (2 if h > 1 else 1), (2 if w > 1 else 1)     # level-0 texels a side
    # Its level-0 rows, with the row before and after them (clamped at the image's
    # edges), one plane a channel.
    rows = np.arange(ry * r0, ry * r1)
    rows = np.clip(np.r_[rows[0] - 1, rows, rows[-1] + 1], 0, h - 1)
    band = np.ascontiguousarray(img[rows].transpose(2, 0, 1)).astype(np.uint16)
    inner = band[:, 1:-1]
    table = _decoded_lookups()
    # The four lookups at +-1/4 texel about each level-0 texel's centre, a quarter
    # texel up or down, then left or right: colour decoded and summed, alpha (not
    # encoded) summed as codes.
    rgb = np.zeros((3,) + inner.shape[1:])
    alpha = np.zeros(inner.shape[1:], np.int64)
    across = np.empty_like(inner)
    for down in (3 * inner + band[:, :-2], 3 * inner + band[:, 2:]):
        three = 3 * down
        for side in (-1, 1):
            if side < 0:                                  # the texel to the left
                across[..., 1:], across[..., 0] = down[..., :-1], down[..., 0]
            else:
                across[..., :-1], across[..., -1] = down[..., 1:], down[..., -1]
            across += three
            rgb += np.take(table, across[:3])
            alpha += across[3]
    total = np.concatenate([rgb, alpha[None] / LOOKUP_SCALE])
    # Summed over each level-1 texel's level-0 texels (an odd last one left out).
    if rx == 2:
        total = total[..., 0:2 * w1:2] + total[..., 1:2 * w1:2]
    if ry == 2:
        total = total[:, 0::2] + total[:, 1::2]
    return (total / (4 * ry * rx)).transpose(1, 2, 0)


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
            self._means[key] = linear_mean(self._image(ref.path), ref.colorspace)
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
        if img.dtype == np.uint8:
            # Its mean too, from the pixels in hand: the irradiance field asks for it
            # (a frame with bounces, the default), and the file is not read twice. An
            # 8-bit image's is a histogram; a deeper one's would decode every texel
            # again, so it waits until the field asks (mean).
            self._means[(path, colorspace)] = linear_mean(img, colorspace)
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
