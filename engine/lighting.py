"""Light numbers that need neither USD nor GL: light volumes, the environment's
spherical harmonics, area-light polygons, and usdview's default rig.

Light volumes: a light's volume reaches the distance R where the largest radiance it
can reflect off a white Lambert surface, I_max / (pi R^2), falls below the scene's
threshold (I_max = max channel of I; for area lights I_max = L * area, the far-field
intensity along the normal). Glossy highlights beyond R are cut off. The threshold is
VOLUME_THRESHOLD = 1e-4 W/(sr m2), but never more than VOLUME_RELATIVE = 1% of what the
scene's brightest light reflects at 1 m (so its volume reaches 10 m at least): an
absolute cut alone drops every light of a dim scene (a 1e-6 W point light reflects
~5e-10 W/(sr m2)), whose image must be the bright one's scaled.

No UsdLux prim on the stage at all: a usdview-style default rig, a headlight (a
distant light travelling along the camera's view direction, E = 2.5 W/m2) plus a
uniform grey dome of radiance 0.2 W/(sr m2): a white Lambert surface facing the camera
reads 2.5/pi + 0.2 ~ 1.0.

Dome: order-2 spherical harmonics irradiance, computed here with numpy in the dome's
own frame (the shaders turn the normal into it); lat-long mapping as UsdLux's (the
stage contract, "World"): in the dome's frame +Y is up (image top), u = (atan2(z, x)
+ pi/2) / 2pi.

Split-sum specular (Karis 2013, Filament's form with multiple scattering): dfg_lut
tabulates, over n.v and perceptual roughness, the GGX directional albedo with F = 1
(its second channel) and the part of it weighted by Schlick's (1 - v.h)^5 (its
first), so a lobe of Schlick reflectance (f0, f90) reflects
    E = f0 (dfg.y - dfg.x) + f90 dfg.x
of a uniform world, and 1 + f0 (1 / dfg.y - 1) scales it for the energy single
scattering loses at high roughness (Kulla and Conty 2017, as Filament does). Its third
channel is the albedo with a dielectric's exact Fresnel at IOR 1.5 (UsdPreviewSurface's
clearcoat), which Cycles uses and Schlick's form undercuts by 10-15% in a furnace."""
from __future__ import annotations

import functools
import math
import os

import numpy as np

from ..core.lights import DISK, POLYGON, RECT, SUN
from .scene import Dome, Light

VOLUME_THRESHOLD = 1e-4
VOLUME_RELATIVE = 1e-2
HEADLIGHT_IRRADIANCE = 2.5
DEFAULT_DOME_RADIANCE = 0.2


def _far_intensity(light: Light):
    """(I_max in W/sr, the light's extent in m) of a local light; a sun's E (W/m2)
    reflects E / pi at any distance, as a light of I = E does at 1 m."""
    c = max(map(float, light.color)) * max(light.diffuse, light.specular, 0.0)
    if light.kind == POLYGON:
        c = max(light.diffuse, light.specular, 0.0) * sum(
            polygon_area(p) * float(np.max(col))
            for p, col in zip(light.polygons, light.polygon_colors))
        corners = np.concatenate(light.polygons) - np.asarray(light.position, np.float64)
        extent = float(np.linalg.norm(corners, axis=1).max())
    elif light.kind in (RECT, DISK):
        c *= light_area(light)
        extent = light.radius if light.kind == DISK else math.hypot(light.width, light.height) / 2
    else:
        extent = light.radius
    return c, extent


def light_area(light: Light) -> float:
    """The emitting area of an area light (rect, disk, an emissive mesh's polygons), m2."""
    if light.kind == RECT:
        return light.width * light.height
    if light.kind == DISK:
        rx, ry = disk_semi_axes(light)
        return math.pi * rx * ry
    return sum(polygon_area(p) for p in light.polygons)


def polygon_area(corners) -> float:
    """The area of a planar polygon (its corners in order, (n, 3))."""
    c = np.asarray(corners, np.float64)
    return 0.5 * float(np.linalg.norm(np.cross(c, np.roll(c, -1, axis=0)).sum(axis=0)))


def volume_threshold(lights) -> float:
    """The scene's threshold (W/(sr m2)) for volume_radius, from all its lights."""
    peak = max((_far_intensity(light)[0] for light in lights), default=0.0)
    at_one_metre = peak / math.pi
    return min(VOLUME_THRESHOLD, VOLUME_RELATIVE * at_one_metre) if peak > 0 else \
        VOLUME_THRESHOLD


def volume_radius(light: Light, threshold: float = VOLUME_THRESHOLD) -> float:
    """Distance beyond which the light reflects < threshold off white Lambert."""
    c, extent = _far_intensity(light)
    if c <= 0:
        return 0.0
    return math.sqrt(c / (math.pi * threshold)) + extent


def disk_semi_axes(light: Light) -> tuple:
    """A disk light's semi-axes along its x and y axes: half its width and height (an
    ellipse's differ), or its radius twice for a disk made with a radius only."""
    if light.width > 0 and light.height > 0:
        return light.width / 2, light.height / 2
    return light.radius, light.radius


def disk_polygon(light: Light, sides: int) -> np.ndarray:
    """Equal-area polygon for a disk light: the regular polygon of the disk's area,
    stretched along y for an ellipse (a linear image of a disk, whose polygon's image
    keeps the area ratio)."""
    scale = math.sqrt(2 * math.pi / (sides * math.sin(2 * math.pi / sides)))
    rx, ry = disk_semi_axes(light)
    ang = np.arange(sides) * 2 * math.pi / sides
    return light.position + (np.outer(np.cos(ang) * rx, light.x_axis)
                             + np.outer(np.sin(ang) * ry, light.y_axis)) * scale


def rect_polygon(light: Light) -> np.ndarray:
    hx, hy = light.x_axis * light.width / 2, light.y_axis * light.height / 2
    c = light.position
    return np.array([c - hx - hy, c + hx - hy, c + hx + hy, c - hx + hy])


def headlight() -> Light:
    """usdview's headlight: a sun along the view, wherever the camera looks."""
    return Light(kind=SUN, name="<headlight>", color=np.full(3, HEADLIGHT_IRRADIANCE),
                 shadow=False, headlight=True)


def default_dome() -> Dome:
    rad = np.full(3, DEFAULT_DOME_RADIANCE)
    return Dome(name="<default dome>", radiance=rad, sh=uniform_sh(rad))


# --- order-2 spherical harmonics -------------------------------------------------
# Irradiance E(n) = sum_lm A_l L_lm Y_lm(n) (Ramamoorthi & Hanrahan 2001). The
# coefficients handed to the shader already include A_l, so the shader only
# evaluates the basis; sh_basis here and sh_irradiance in lib.glsl must agree.
_A = np.array([math.pi] + [2 * math.pi / 3] * 3 + [math.pi / 4] * 5)


def sh_basis(d: np.ndarray) -> np.ndarray:
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, 0.282095),
        0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1),
        1.092548 * x * z, 0.546274 * (x * x - y * y)], axis=-1)


def uniform_sh(radiance) -> np.ndarray:
    sh = np.zeros((9, 3))
    sh[0] = np.asarray(radiance, float) * 4 * math.pi * 0.282095 * _A[0]
    return sh


def downsample_latlong(img: np.ndarray, width: int = 256) -> np.ndarray:
    """Box-average a lat-long image to at most `width` texels across (so a small sun
    keeps its energy): order-2 harmonics need no more."""
    h, w = img.shape[:2]
    f = max(1, w // width)
    if f == 1:
        return img.astype(np.float64)
    rows = np.add.reduceat(img.astype(np.float64), np.arange(0, h, f), axis=0)
    blocks = np.add.reduceat(rows, np.arange(0, w, f), axis=1)
    counts = np.outer(np.diff(np.r_[np.arange(0, h, f), h]), np.diff(np.r_[np.arange(0, w, f), w]))
    return blocks / counts[..., None]


def latlong_dirs(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Dome-frame directions of pixel centres (row 0 = top = +Y) and solid angles."""
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2 * math.pi - math.pi / 2
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)], axis=-1)
    dw = (2 * math.pi / w) * (math.pi / h) * np.sin(th)
    return d, dw


def latlong_sh(img: np.ndarray) -> np.ndarray:
    """(9, 3) irradiance harmonics of a lat-long radiance image (H, W, >=3), in the
    dome's own frame. Each texel is weighted by its exact solid angle (the band
    between its latitudes), so a uniform image gives exactly uniform_sh."""
    img = downsample_latlong(np.asarray(img)[..., :3])
    h, w = img.shape[:2]
    d, _ = latlong_dirs(h, w)
    edges = np.cos(np.arange(h + 1) / h * math.pi)
    dw = np.broadcast_to(((edges[:-1] - edges[1:]) * 2 * math.pi / w)[:, None], (h, w))
    Y = sh_basis(d)                                   # (h, w, 9)
    L = np.einsum("hwk,hwc,hw->kc", Y, img, dw)       # projection of radiance
    return L * _A[:, None]


# --- split-sum specular ------------------------------------------------------------
DFG_SIZE = 32          # n.v x roughness texels; the table is smooth, sampled bilinearly
DFG_SAMPLES = 1024


def ggx_alpha(roughness):
    """GGX alpha of a perceptual roughness, as shaders/lib.glsl's ggx_alpha."""
    return np.maximum(np.asarray(roughness, float) ** 2, 2e-3)


def hammersley(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The n points of the Hammersley set in [0, 1)^2: (i + 0.5) / n and the radical
    inverse of i in base 2."""
    i = np.arange(n, dtype=np.uint32)
    bits = i.copy()
    bits = ((bits << 16) | (bits >> 16)) & 0xFFFFFFFF
    bits = ((bits & 0x55555555) << 1) | ((bits & 0xAAAAAAAA) >> 1)
    bits = ((bits & 0x33333333) << 2) | ((bits & 0xCCCCCCCC) >> 2)
    bits = ((bits & 0x0F0F0F0F) << 4) | ((bits & 0xF0F0F0F0) >> 4)
    bits = ((bits & 0x00FF00FF) << 8) | ((bits & 0xFF00FF00) >> 8)
    return (i + 0.5) / n, bits.astype(np.float64) / 2.0 ** 32


COAT_IOR = 1.5   # UsdPreviewSurface's clearcoat (and Blender's default dielectric)


def fresnel_dielectric(cos_i, eta):
    """Unpolarised Fresnel reflectance of a dielectric of relative IOR eta (> 1) at
    incidence cosine cos_i, as lib.glsl's fresnel_dielectric (and Cycles)."""
    c = np.abs(np.asarray(cos_i, float))
    g2 = eta * eta - 1 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    a, b = (g - c) / (g + c), (c * (g + c) - 1) / (c * (g - c) + 1)
    return np.where(g2 > 0, 0.5 * a * a * (1 + b * b), 1.0)


def _lobe_samples(nov, roughness, samples):
    """GGX lobes by importance sampling D, for each (n.v, perceptual roughness) row:
    the light directions l (x towards v's side of the normal, z the normal), the half
    vectors' v.h, and each sample's weight in the integral of f cos with F = 1
    (height-correlated Smith visibility, lib.glsl's v_smith; 0 below the horizon)."""
    nov = np.clip(nov.reshape(-1, 1), 1e-4, 1.0)
    a = ggx_alpha(roughness.reshape(-1, 1))
    u1, u2 = hammersley(samples)
    phi = 2 * math.pi * u1[None, :]
    cos_h = np.sqrt((1 - u2[None, :]) / (1 + (a * a - 1) * u2[None, :]))
    sin_h = np.sqrt(1 - cos_h * cos_h)
    vx, vz = np.sqrt(1 - nov * nov), nov                     # v in the xz plane
    voh = vx * sin_h * np.cos(phi) + vz * cos_h
    nol = 2 * voh * cos_h - vz
    a2 = a * a
    gv = nol * np.sqrt(nov * nov * (1 - a2) + a2)
    gl = nov * np.sqrt(np.maximum(nol, 0) ** 2 * (1 - a2) + a2)
    vis = 0.5 / np.maximum(gv + gl, 1e-12)
    weight = np.where(nol > 0, 4 * vis * nol * voh / cos_h, 0.0)
    l = np.stack([2 * voh * sin_h * np.cos(phi) - vx, 2 * voh * sin_h * np.sin(phi),
                  nol + 0 * vx], axis=-1)
    return l, voh, weight


def dfg_terms(nov, roughness, samples: int = DFG_SAMPLES, fresnel_ior=None) -> np.ndarray:
    """(..., 2): the GGX integrals (sum of Fc G_vis, sum of G_vis) for n.v and
    perceptual roughness (broadcast), by importance sampling D (height-correlated
    Smith visibility, lib.glsl's v_smith). With fresnel_ior, (...,): the integral of
    F G_vis with a dielectric's exact Fresnel, its single-scattering albedo."""
    nov, roughness = np.broadcast_arrays(np.asarray(nov, float), np.asarray(roughness, float))
    shape = nov.shape
    _, voh, weight = _lobe_samples(nov, roughness, samples)
    if fresnel_ior is not None:
        return (weight * fresnel_dielectric(voh, fresnel_ior)).mean(axis=1).reshape(shape)
    fc = (1 - voh) ** 5
    out = np.stack([(weight * fc).mean(axis=1), weight.mean(axis=1)], axis=-1)
    return out.reshape(shape + (2,))


def lobe_moments(nov, roughness, samples: int = DFG_SAMPLES, fresnel_ior=None) -> np.ndarray:
    """(..., 8): the first and second moments of the light directions a GGX lobe
    reflects towards v, weighted as it reflects them (f cos with F = 1, normalised: the
    lobe's share of each direction), in the frame t (the tangent towards v), b, n:
    (E[l_t], E[l_b] (0: the lobe is symmetric about the plane of n and v), E[l_n], E[l_t l_n], E[l_t^2], E[l_b^2], E[l_n^2], 0). Any
    quadratic function of direction averages over the lobe exactly from them, as
    order-2 spherical harmonics do (shaders/environment.glsl dome_specular). With
    fresnel_ior, of the lobe weighted by a dielectric's exact Fresnel as well, which
    leans it towards grazing directions."""
    nov, roughness = np.broadcast_arrays(np.asarray(nov, float), np.asarray(roughness, float))
    shape = nov.shape
    l, voh, weight = _lobe_samples(nov, roughness, samples)
    if fresnel_ior is not None:
        weight = weight * fresnel_dielectric(voh, fresnel_ior)
    w = weight / np.maximum(weight.sum(axis=1, keepdims=True), 1e-30)
    m = np.einsum("ps,psk->pk", w, l)
    s = np.einsum("ps,psk->pk", w, l * l)
    tn = np.einsum("ps,ps->p", w, l[..., 0] * l[..., 2])
    out = np.stack([m[:, 0], 0 * tn, m[:, 2], tn, s[:, 0], s[:, 1], s[:, 2], 0 * tn], axis=-1)
    return out.reshape(shape + (8,))


def _trapezoid(y, x):
    """The trapezoid rule along the last axis."""
    return ((y[..., 1:] + y[..., :-1]) * 0.5 * np.diff(x)).sum(axis=-1)


TABLES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "shaders",
                      "tables")


def _stored(name: str, compute) -> np.ndarray:
    """shaders/tables/<name>.npy, the table `compute()` makes, written by
    shaders/tables/make_tables.py so that no process pays for the integration (about
    0.15 s for the split-sum table on 2 cores); computed when the file is missing or
    not of the computed table's shape and type (tests/test_shading.py checks that it
    equals the computation)."""
    try:
        table = np.load(os.path.join(TABLES, name + ".npy"), allow_pickle=False)
    except (OSError, ValueError):
        return compute()
    if table.dtype != np.float32 or table.shape != TABLE_SHAPES[name] or \
            not np.isfinite(table).all():
        return compute()
    return table


@functools.lru_cache(maxsize=1)
def dfg_lut() -> np.ndarray:
    """The split-sum table the shaders read (compute_dfg_lut), stored."""
    return _stored("dfg_lut", compute_dfg_lut)


DFG_BLOCKS = 5         # the table's blocks of DFG_SIZE rows: the albedos, the lobes' moments (4)


def compute_dfg_lut(size: int = DFG_SIZE) -> np.ndarray:
    """(DFG_BLOCKS * size, size, 4) float32: blocks of `size` rows one under the other
    (lib.glsl dfg_block), in each row j = roughness j / (size - 1), column i = n.v
    i / (size - 1), the values at texel centres (lib.glsl dfg_uv), so that n.v and
    roughness 0 and 1 are in it, not clamped half a texel short (E at n.v 1 and
    roughness 1 read 0.326 that way; it is 0.307).
    Block 0: dfg_terms, the exact-Fresnel albedo at COAT_IOR, and the lobe's albedo
    averaged over the hemisphere, E_avg = 2 * integral of E(mu) mu (the same in every
    column; Cycles' multiple-scattering Fresnel needs it: lib.glsl lobe_energy).
    Blocks 1 and 2: lobe_moments' eight channels, four each (the dome's reflections),
    E[l_t] and E[l_t l_n] over sin(theta_v); blocks 3 and 4 the same with the exact
    Fresnel of IOR 1.5 (dielectric lobes)."""
    c = np.linspace(0.0, 1.0, size)
    # E[l_t] and E[l_t l_n] go as sin(theta_v) = sqrt(1 - n.v^2), whose slope is
    # infinite at n.v = 1, so that a bilinear lookup bent a mirror's direction by up to
    # 3 degrees: stored divided by it (lib.glsl make_lobe multiplies it back), at
    # n.v = 1 extrapolated from the two columns before.
    sin_v = np.sqrt(1.0 - c * c)[:, None]
    odd = np.array([1, 0, 0, 1, 0, 0, 0, 0], bool)

    def moments(r, **kw):
        m = lobe_moments(c, r, **kw)
        ratio = m[:-1] / sin_v[:-1]
        ratio = np.concatenate([ratio, 2.0 * ratio[-1:] - ratio[-2:-1]])
        return np.where(odd, ratio, m)
    rows = [np.concatenate([dfg_terms(c, r), dfg_terms(c, r, fresnel_ior=COAT_IOR)[:, None],
                            moments(r), moments(r, fresnel_ior=COAT_IOR)],
                           axis=1) for r in c]                      # row by row: cache-sized
    table = np.stack(rows)                                          # (size, size, 19)
    e_avg = 2.0 * _trapezoid(table[:, :, 1] * c[None, :], c)
    albedos = np.concatenate([table[:, :, :3], np.repeat(e_avg[:, None, None], size, axis=1)],
                             axis=2)
    return np.concatenate([albedos, table[:, :, 3:7], table[:, :, 7:11], table[:, :, 11:15],
                           table[:, :, 15:19]], axis=0).astype(np.float32)


def specular_albedo(f0, f90, nov, roughness) -> np.ndarray:
    """Directional albedo of a Schlick-GGX lobe with multiple scattering, as the
    shaders compute it from the table for a metal: what it reflects of a uniform
    world (a dielectric's they scale by the exact-Fresnel ratio, lib.glsl
    make_surface)."""
    x, y = np.moveaxis(dfg_terms(nov, roughness), -1, 0)
    mu = np.linspace(0.0, 1.0, DFG_SIZE)
    e_avg = 2.0 * _trapezoid(dfg_terms(mu, roughness)[:, 1] * mu, mu)
    f0 = np.asarray(f0, float)
    fss = f0 + (f90 - f0) / 21.0
    fms = fss * e_avg / (1.0 - fss * (1.0 - e_avg))
    return (f0 * (y - x) + f90 * x) * (1 + fms * (1 / y - 1))


def velvet_brdf(v, l, sigma) -> np.ndarray:
    """Cycles' Ashikhmin velvet BRDF (shaders/sheen.glsl brdf_sheen, mode 2) for unit
    directions v (to the viewer) and l (to the light) about the normal +Z, broadcast."""
    v, l = np.asarray(v, float), np.asarray(l, float)
    sigma = np.maximum(np.asarray(sigma, float), 0.01)
    nov, nol = v[..., 2], l[..., 2]
    h = v + l
    h = h / np.maximum(np.linalg.norm(h, axis=-1, keepdims=True), 1e-12)
    noh, voh = h[..., 2], np.abs(np.sum(v * h, axis=-1))
    valid = (nov > 0) & (nol > 0) & (np.abs(noh) < 1 - 1e-5) & (voh > 1e-5)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = np.maximum(noh / voh, 1e-5)
        g = np.minimum(1.0, 2 * ratio * np.minimum(nov, nol))
        sin2 = 1 - noh * noh
        d = np.exp(-noh * noh / (sin2 * sigma * sigma)) / (sigma * sigma * math.pi * sin2 * sin2)
        f = 0.25 * d * g / (nov * nol)
    return np.where(valid, f, 0.0)


VELVET_SIZE = 16       # n.v x roughness texels of the velvet albedo


@functools.lru_cache(maxsize=1)
def velvet_albedo_lut() -> np.ndarray:
    """The velvet albedo table the shaders read (compute_velvet_albedo_lut), stored."""
    return _stored("velvet_albedo", compute_velvet_albedo_lut)


def compute_velvet_albedo_lut(size: int = VELVET_SIZE, steps: int = 64) -> np.ndarray:
    """(size, size, 1) float32, row j = roughness j / (size - 1), column i = n.v
    i / (size - 1) (texel centres, as dfg_lut): the velvet lobe's directional albedo,
    the integral of f cos over the hemisphere of light directions (midpoint rule in
    theta, phi; the lobe is mirror-symmetric in phi)."""
    theta = (np.arange(steps) + 0.5) * (math.pi / 2) / steps
    phi = (np.arange(2 * steps) + 0.5) * math.pi / (2 * steps)
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    l = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    weight = np.cos(th) * np.sin(th) * (math.pi / 2 / steps) * (math.pi / (2 * steps)) * 2
    c = np.linspace(0.0, 1.0, size)
    table = np.zeros((size, size, 1), np.float32)
    for i, nov in enumerate(np.maximum(c, 1e-3)):
        v = np.array([math.sqrt(1 - nov * nov), 0.0, nov])
        f = velvet_brdf(v, l[None], c[:, None, None])          # (roughness, theta, phi)
        table[:, i, 0] = np.sum(f * weight, axis=(1, 2))
    return table


# The stored tables' shapes (float32), as their compute_ functions make them.
TABLE_SHAPES = {"dfg_lut": (DFG_BLOCKS * DFG_SIZE, DFG_SIZE, 4), "velvet_albedo": (VELVET_SIZE, VELVET_SIZE, 1)}
