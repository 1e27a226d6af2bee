"""Linearly transformed cosines (Heitz, Dupuy, Hill and Neubelt 2016, "Real-Time
Polygonal-Light Shading with Linearly Transformed Cosines") for the GGX lobe the shaders
use (shaders/lib.glsl: D GGX, height-correlated Smith visibility, alpha = roughness^2
at least 2e-3), with F = 1: the lobe's albedo and its Fresnel come from the split-sum
table, so a polygon's share of the lobe is all this table holds.

A clamped cosine distribution D_o(w) = max(w_z, 0) / pi, its directions taken through a
3x3 matrix M, has the density D(w) = D_o(w') |det M^-1| / |M^-1 w|^3, w' = M^-1 w / |.|;
its integral over a polygon is the cosine's over the polygon taken through M^-1, in
closed form (Lambert's edge integral after clipping to the horizon: shaders/ltc.glsl).
For each (n.v, roughness) M is fitted so that D follows the lobe f cos / E (E the
lobe's albedo): M = [X Y Z] [[a, 0, b], [0, c, 0], [0, 0, 1]], Z the lobe's mean
direction, in the frame (t, b, n) of lib.glsl's Lobe (t the tangent towards v). The
shaders read M^-1 = [[m00, 0, m02], [0, 1, 0], [m20, 0, m22]] (scaled so that its
middle entry is 1: the integral does not see a scale), as ltc_table lays it out.

shaders/tables/fit_ltc.py fits the table (minutes) and stores it beside the other
tables; tests/test_ltc.py fits a few texels again and checks the shaders' integral
against the lobe integrated over polygons by sampling."""
from __future__ import annotations

import functools
import math
import os

import numpy as np

from .lighting import TABLES, ggx_alpha, hammersley

LTC_SIZE = 64            # n.v x roughness texels, at i / (size - 1) as dfg_lut's
FIT_SAMPLES = 1024       # directions drawn from each of the two distributions per fit


def _normalize(w):
    return w / np.maximum(np.linalg.norm(w, axis=-1, keepdims=True), 1e-30)


def view_direction(nov):
    """v in the lobe's frame (t, b, n) for n.v (clamped as lib.glsl's s.NoV)."""
    c = min(max(float(nov), 1e-4), 1.0)
    return np.array([math.sqrt(1.0 - c * c), 0.0, c])


def ggx_cos(v, l, alpha):
    """f cos of the GGX lobe with F = 1 towards unit directions l (..., 3) about the
    normal +Z, as lib.glsl's d_ggx x v_smith x n.l; 0 below the horizon."""
    nov, nol = v[2], l[..., 2]
    h = _normalize(l + v)
    a2 = alpha * alpha
    d = a2 / (math.pi * (h[..., 2] ** 2 * (a2 - 1.0) + 1.0) ** 2)
    nol_c = np.maximum(nol, 0.0)
    gv = nol_c * math.sqrt(nov * nov * (1.0 - a2) + a2)
    gl = nov * np.sqrt(nol_c * nol_c * (1.0 - a2) + a2)
    return np.where(nol > 0.0, d * 0.5 / np.maximum(gv + gl, 1e-30) * nol_c, 0.0)


def ggx_samples(v, alpha, n):
    """n directions drawn by sampling GGX's D (Hammersley), their pdf, and f cos / pdf
    (F = 1: the integral of f cos is their mean over all, those below the horizon
    counting 0)."""
    u1, u2 = hammersley(n)
    phi = 2.0 * math.pi * u1
    cos_h = np.sqrt((1.0 - u2) / (1.0 + (alpha * alpha - 1.0) * u2))
    sin_h = np.sqrt(1.0 - cos_h * cos_h)
    h = np.stack([sin_h * np.cos(phi), sin_h * np.sin(phi), cos_h], axis=-1)
    voh = h @ v
    l = 2.0 * voh[:, None] * h - v
    pdf = ggx_pdf(v, l, alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(pdf > 0.0, ggx_cos(v, l, alpha) / pdf, 0.0)
    return l, pdf, weight


def ggx_pdf(v, l, alpha):
    """The density of ggx_samples' directions: D(h) n.h / (4 v.h)."""
    h = _normalize(l + v)
    a2 = alpha * alpha
    d = a2 / (math.pi * (h[..., 2] ** 2 * (a2 - 1.0) + 1.0) ** 2)
    voh = h @ v
    return np.where((voh > 0.0) & (h[..., 2] > 0.0), d * h[..., 2] / np.maximum(4.0 * voh, 1e-30),
                    0.0)


def ltc_density(minv, w):
    """D(w) of the cosine taken through M (minv = M^-1, any scale), unit w (..., 3)."""
    minv = np.asarray(minv, float)
    minv = minv / abs(np.linalg.det(minv)) ** (1.0 / 3.0)
    wo = w @ minv.T
    length = np.linalg.norm(wo, axis=-1)
    return np.maximum(wo[..., 2] / length, 0.0) / math.pi / length ** 3


def _cosine_samples(n):
    u1, u2 = hammersley(n)
    r, phi = np.sqrt(u2), 2.0 * math.pi * u1
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - u2)], axis=-1)


def lobe_frame(v, alpha, n=FIT_SAMPLES):
    """(E, [X Y Z]): the lobe's albedo with F = 1 and the rotation whose Z is its
    mean direction (in the plane of n and v)."""
    l, _, weight = ggx_samples(v, alpha, n)
    albedo = float(weight.mean())
    mean = (weight[:, None] * l).sum(axis=0)
    mean[1] = 0.0
    z = mean / np.linalg.norm(mean) if np.linalg.norm(mean) > 0 else np.array([0.0, 0.0, 1.0])
    rotation = np.column_stack([[z[2], 0.0, -z[0]], [0.0, 1.0, 0.0], z])
    return albedo, rotation


def fit_matrix(nov, roughness, start=None, n=FIT_SAMPLES):
    """(M^-1 as the shaders read it (3, 3), the fitted (a, c, b)): the LTC closest to the
    lobe f cos / E in the L3 norm of Heitz et al., estimated from directions drawn from
    both distributions (balance heuristic) and minimised by Nelder-Mead from `start`
    (the neighbouring texel's (a, c, b); else the lobe's alpha)."""
    from scipy.optimize import minimize      # only the fit needs it, offline
    v = view_direction(nov)
    alpha = float(ggx_alpha(roughness))
    albedo, rotation = lobe_frame(v, alpha, n)
    ggx_l, ggx_p, _ = ggx_samples(v, alpha, n)
    ggx_f = ggx_cos(v, ggx_l, alpha) / albedo          # what does not depend on M, once
    cos_w = _cosine_samples(n)

    def matrix(q):          # (log a, log c, b / a): steps relative to the lobe's size
        a, c = math.exp(q[0]), math.exp(q[1])
        return rotation @ np.array([[a, 0.0, q[2] * a], [0.0, c, 0.0], [0.0, 0.0, 1.0]])

    def error(q):
        m = matrix(q)
        det = math.exp(q[0] + q[1])                    # det M = a c
        # The LTC's own directions l = M w / |M w|, whose density is w_z / pi |M w|^3 / det M.
        mw = cos_w @ m.T
        length = np.linalg.norm(mw, axis=-1)
        ltc_l = mw / length[:, None]
        g_own = cos_w[:, 2] / math.pi * length ** 3 / det
        f_own = ggx_cos(v, ltc_l, alpha) / albedo
        e_own = np.abs(f_own - g_own) ** 3 / (g_own + ggx_pdf(v, ltc_l, alpha))
        g = ltc_density(np.linalg.inv(m), ggx_l)
        e_ggx = np.abs(ggx_f - g) ** 3 / np.maximum(g + ggx_p, 1e-30)
        return (e_own.sum() + e_ggx.sum()) / (2 * n)

    a, c, b = start if start is not None else (alpha, alpha, 0.0)
    scale = albedo ** 3 / alpha ** 4          # the error's size: a density of ~1 / alpha^2
    best = minimize(lambda q: error(q) / scale, [math.log(a), math.log(c), b / a],
                    method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-6, "maxiter": 300})
    q = best.x
    minv = np.linalg.inv(matrix(q))
    return minv / minv[1, 1], (math.exp(q[0]), math.exp(q[1]), q[2] * math.exp(q[0]))


def fit_row(j: int, size: int = LTC_SIZE) -> np.ndarray:
    """(size, 4) float32: row j of the table (roughness j / (size - 1)), column i = n.v
    i / (size - 1) (lib.glsl table_uv), channels (m00, m02, m20, m22) of M^-1. Fitted
    from n.v = 1 (a lobe symmetric about the normal) down, each texel starting from its
    neighbour's fit; rows are independent."""
    c = np.linspace(0.0, 1.0, size)
    row = np.zeros((size, 4), np.float32)
    start = None
    for i in range(size - 1, -1, -1):
        minv, start = fit_matrix(c[i], c[j], start)
        row[i] = minv[0, 0], minv[0, 2], minv[2, 0], minv[2, 2]
    return row


LTC_FILE = os.path.join(TABLES, "ltc_ggx.npy")


@functools.lru_cache(maxsize=1)
def ltc_lut() -> np.ndarray:
    """The stored table (shaders/tables/fit_ltc.py writes it; fitting it again takes
    minutes, so a missing or malformed file is an error, not a fit)."""
    try:
        table = np.load(LTC_FILE, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise RuntimeError(f"{LTC_FILE}: the area lights' LTC table cannot be read ({exc}); "
                           "run shaders/tables/fit_ltc.py") from exc
    if table.dtype != np.float32 or table.shape != (LTC_SIZE, LTC_SIZE, 4) or \
            not np.isfinite(table).all():
        raise RuntimeError(f"{LTC_FILE}: not a finite float32 {LTC_SIZE}x{LTC_SIZE}x4 table; "
                           "run shaders/tables/fit_ltc.py")
    return table


def table_matrix(table, nov, roughness) -> np.ndarray:
    """M^-1 read from `table` as the shaders do: bilinear, at texel centres."""
    size = table.shape[0]
    x = np.clip(nov, 0.0, 1.0) * (size - 1)
    y = np.clip(roughness, 0.0, 1.0) * (size - 1)
    i, j = min(int(x), size - 2), min(int(y), size - 2)
    fx, fy = x - i, y - j
    t = (table[j, i] * (1 - fx) * (1 - fy) + table[j, i + 1] * fx * (1 - fy)
         + table[j + 1, i] * (1 - fx) * fy + table[j + 1, i + 1] * fx * fy)
    return np.array([[t[0], 0.0, t[1]], [0.0, 1.0, 0.0], [t[2], 0.0, t[3]]])


def polygon_hits(l, polygon):
    """Which directions l (n, 3) from the origin meet a convex planar polygon (vertices
    (k, 3) about the origin): with ggx_samples, the GGX lobe integrated over a polygon
    by sampling, the reference the shaders' LTC integral is tested against."""
    polygon = np.asarray(polygon, float)
    normal = np.cross(polygon[1] - polygon[0], polygon[2] - polygon[0])
    denom = l @ normal
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(np.abs(denom) > 1e-30, (polygon[0] @ normal) / denom, -1.0)
    hit = t > 0.0
    points = l * t[:, None]
    for k in range(len(polygon)):
        a, b = polygon[k], polygon[(k + 1) % len(polygon)]
        hit &= (np.cross(b - a, points - a) @ normal) >= 0.0
    return hit
