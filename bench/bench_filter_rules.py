"""How accurately a texture lookup's probes integrate Cycles' pixel filter, in one
dimension: the probe grid that medium's lookups take (material.glsl sample_map, a grid
over the filter's reach, a texel or less apart, weighted by the filter), Gauss rules
with the filter as their weight, and the sub-sample grids of high and ultra (one point
a sub-pixel, weighted by the filter). Each lookup is Cycles': linear interpolation of
an 8-bit sRGB image's stored values, decoded per probe. The error is the RMS, over
random images (0/1 texels, or uniform ones) and offsets, against the filter's integral
on a fine grid. Prints a row per texels-a-pixel; docs/rendering.md, "Textures".

    python bench/bench_filter_rules.py
"""
from __future__ import annotations

import argparse

import numpy as np

from lantern.engine.gpu.passes.antialias import FILTER_WIDTH, blackman_harris, downsample_taps
from lantern.engine.textures import srgb_to_linear

FINE = np.linspace(-FILTER_WIDTH, FILTER_WIDTH, 3001)
FILTER = blackman_harris(FINE)
FILTER /= FILTER.sum()                       # the filter on FINE, summing to 1


def lookup(texels, u):
    """Linear interpolation of stored values at texel coordinate u (repeat), decoded."""
    f = u - 0.5
    i = np.floor(f).astype(int)
    a = f - i
    n = len(texels)
    return srgb_to_linear(texels[i % n] * (1 - a) + texels[(i + 1) % n] * a)


def grid(n):
    """medium's probes: n over the reach, weighted by the filter."""
    o = FILTER_WIDTH * ((2 * np.arange(n) + 1) / n - 1)
    w = blackman_harris(o)
    return o, w / w.sum()


def gauss(n):
    """The n-point Gauss rule with the filter as its weight (Golub-Welsch on a fine grid)."""
    w = FILTER
    p_prev, p, norm_prev, a, b = np.zeros_like(FINE), np.ones_like(FINE), None, [], []
    for k in range(n):
        norm = np.sum(w * p * p)
        a.append(np.sum(w * FINE * p * p) / norm)
        if k:
            b.append(norm / norm_prev)
        p_prev, p, norm_prev = p, (FINE - a[-1]) * p - (b[-1] if k else 0.0) * p_prev, norm
    jacobi = np.diag(a) + np.diag(np.sqrt(b), 1) + np.diag(np.sqrt(b), -1)
    nodes, vectors = np.linalg.eigh(jacobi)
    return nodes, vectors[0] ** 2


def sub_samples(k):
    """high (k = 2) and ultra (3): one point a sub-pixel, weighted by the filter
    (the supersample reduction's own taps)."""
    offsets, weights = downsample_taps(k)
    return (offsets + 0.5) / k - 0.5, weights


def rms_error(rule, texels_per_pixel, kind, rng, trials=400):
    nodes, weights = rule
    errors = []
    for _ in range(trials):
        texels = rng.integers(0, 2, 64).astype(float) if kind == "0/1" else rng.random(64)
        u0 = rng.random() * 64
        exact = np.sum(FILTER * lookup(texels, u0 + FINE * texels_per_pixel))
        errors.append(np.sum(weights * lookup(texels, u0 + nodes * texels_per_pixel)) - exact)
    return float(np.sqrt(np.mean(np.square(errors))))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print("RMS error of a lookup against the pixel filter's integral (1 = full scale)")
    for kind in ("0/1", "uniform"):
        print(f"{kind + ' texels':<16} | medium's grid | Gauss, a probe fewer | high | ultra "
              f"(probes a side)")
        for l in (0.35, 0.5, 0.7, 0.9, 1.1, 1.3, 1.6, 1.9):
            k = max(int(np.ceil(2 * FILTER_WIDTH * l)), 1)
            k += k == 2                          # material.glsl: never two
            n = max(k - 1, 2)
            print(f"  {l:4.2f} texels/px | {rms_error(grid(k), l, kind, rng):.4f} ({k})    | "
                  f"{rms_error(gauss(n), l, kind, rng):.4f} ({n})           | "
                  f"{rms_error(sub_samples(2), l, kind, rng):.4f} | "
                  f"{rms_error(sub_samples(3), l, kind, rng):.4f}")


if __name__ == "__main__":
    main()
