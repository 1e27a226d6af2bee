"""Anti-aliasing of the deferred image (seed 004: a G-buffer cannot be multisampled):

  samples > 1   jittered accumulation (a still's TAA, the F12 and command-line
                presets high and ultra): the frame is drawn k x k times with the
                projection moved by a sub-pixel offset (passes/view.py), and the light
                of the drawings is summed here, each weighted by Cycles' pixel filter
                (Blackman-Harris, 1.5 px either side) at its offset: a quadrature of the
                filtered image Cycles computes. Kept shadow maps are drawn once; the
                ambient occlusion's pattern turns with each drawing, so it averages
                too. Render passes come from the last drawing, the one nearest the
                pixel centre.
  1 sample      FXAA (passes/post.py), when the preset asks for it.

Measured against supersampling (the same number of samples in one larger drawing,
down-sampled with the same filter): see the README, "Anti-aliasing".

reads: hdr (this drawing's light, coverage in alpha)   writes: hdr (the weighted sum,
last drawing only)"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..framegraph import Pass
from ..programs import UNITS, set_uniform

FILTER_WIDTH = 1.5          # pixels, Cycles' default (Film > Pixel Filter > Width)


def blackman_harris(x, width=2.0 * FILTER_WIDTH):
    """Cycles' film filter: Blackman-Harris over [-width/2, width/2]. Cycles doubles
    the user's width for this filter (scene/film.cpp filter_table), so its 1.5 px
    filter reaches 1.5 px either side."""
    t = 2 * np.pi * (np.asarray(x, float) / width + 0.5)
    w = 0.35875 - 0.48829 * np.cos(t) + 0.14128 * np.cos(2 * t) - 0.01168 * np.cos(3 * t)
    return np.where(np.abs(x) <= width / 2, w, 0.0)


@functools.lru_cache(maxsize=1)
def _inverse_cdf(width=2.0 * FILTER_WIDTH, n=1024):
    x = np.linspace(-width / 2, width / 2, n)
    cdf = np.cumsum(blackman_harris(x, width))
    cdf = (cdf - cdf[0]) / (cdf[-1] - cdf[0])
    return x, cdf


def jitter_offsets(samples: int) -> tuple[np.ndarray, np.ndarray]:
    """((n, 2) pixel offsets, (n,) weights): the pixel filter as a stratified
    quadrature, a k x k grid (k = round(sqrt(samples))) at the filter's quantiles
    (i + 0.5) / k in x and in y, equal weights; the centre-most drawing last. A few
    regular samples, not random ones: too few to importance-sample edges without
    visible noise."""
    k = max(int(round(math.sqrt(max(samples, 1)))), 1)
    if k == 1:
        return np.zeros((1, 2)), np.ones(1)
    x, cdf = _inverse_cdf()
    c = np.interp((np.arange(k) + 0.5) / k, cdf, x)
    gx, gy = np.meshgrid(c, c)
    offsets = np.stack([gx.ravel(), gy.ravel()], -1)
    order = np.argsort(-np.hypot(offsets[:, 0], offsets[:, 1]), kind="stable")
    return offsets[order], np.full(len(offsets), 1.0 / len(offsets))


def jittered(camera, offset, size):
    """The camera with its projection moved by `offset` pixels (clip-space shift
    scaled by w, so perspective and orthographic alike)."""
    if not np.any(offset):
        return camera
    from dataclasses import replace
    p = np.array(camera.proj, np.float64)
    w, h = size
    p[0] = p[0] + (2.0 * offset[0] / w) * p[3]
    p[1] = p[1] + (2.0 * offset[1] / h) * p[3]
    return replace(camera, proj=p)


class AccumulatePass(Pass):
    name = "accumulate"
    reads = ("hdr",)
    writes = ("hdr",)

    def __init__(self, ctx, pool, programs):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self._sum = None             # float32 sum, kept across one render's drawings

    def needed(self, frame):
        return frame.samples > 1

    def execute(self, frame, board):
        ctx = self.ctx
        if frame.sample == 0:
            self._sum = self.pool.acquire(frame.size, "rgba32f")
            fbo = self.pool.framebuffer([self._sum])
            fbo.use()
            fbo.clear(0.0, 0.0, 0.0, 0.0)
        fbo = self.pool.framebuffer([self._sum])
        fbo.use()
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        prog = self.programs.get("fullscreen.vert", "post.frag", ["POST_SCALE"])
        board["hdr"].use(UNITS["post_src"])
        set_uniform(prog, "scale", frame.weight)
        set_uniform(prog, "alpha_scale", frame.weight)
        self.programs.fullscreen(prog)
        ctx.disable(ctx.BLEND)
        if frame.sample == frame.samples - 1:
            # The average goes back into the frame's HDR target.
            self.pool.framebuffer([board["hdr"]]).use()
            self._sum.use(UNITS["post_src"])
            set_uniform(prog, "scale", 1.0)         # the weights sum to 1
            set_uniform(prog, "alpha_scale", 1.0)
            self.programs.fullscreen(prog)
            self.pool.release(self._sum)
            self._sum = None

    def release(self):
        if self._sum is not None:
            self.pool.release(self._sum)
            self._sum = None
