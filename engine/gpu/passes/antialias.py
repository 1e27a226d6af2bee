"""Anti-aliasing of the deferred image (a G-buffer cannot be multisampled: docs/design.md,
Deferred shading).

  supersample k > 1   (the presets high and ultra, for F12 and the command line) the
                      frame is drawn k times wider and taller, and this pass filters
                      it down with Cycles' pixel filter: Blackman-Harris reaching
                      1.5 px either side of each pixel centre (Cycles doubles the
                      user's 1.5 px width for this filter, scene/film.cpp
                      filter_table), separably, in two draws. A texture lookup
                      filters its sub-pixel (shaders/material.glsl sample_map).
  k = 1               FXAA at geometric edges (passes/post.py), when the preset asks;
                      texture lookups filter with the same pixel filter
                      (BLACKMAN_HARRIS, FILTER_WIDTH: material.glsl sample_map).

Chosen by measurement (bench/bench_antialias.py, docs/rendering.md "Anti-aliasing"): against
jittered accumulation of as many drawings (a still's TAA) supersampling had the lower
error on every corpus scene at every sample count and took less time, since one
drawing of k^2 pixels costs less than k^2 drawings, and its filter reaches the
neighbouring pixels' samples as Cycles' does.

reads: hdr (k x the image size)   writes: hdr (the image size; later passes draw at it)
"""
from __future__ import annotations

import numpy as np

from ..framegraph import TARGETS, Pass
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program

FILTER_WIDTH = 1.5          # pixels, Cycles' default (Film > Pixel Filter > Width)
MAX_TAPS = 64               # shaders/post.glsl POST_DOWNSAMPLE


# Blackman-Harris's cosine terms 0..3 (Cycles' scene/film.cpp): this filter and the
# one each texture lookup of an image not supersampled filters with (material.glsl).
BLACKMAN_HARRIS = (0.35875, -0.48829, 0.14128, -0.01168)


def blackman_harris(x, width=2.0 * FILTER_WIDTH):
    """Cycles' film filter: Blackman-Harris over [-width/2, width/2]."""
    t = 2 * np.pi * (np.asarray(x, float) / width + 0.5)
    w = sum(a * np.cos(n * t) for n, a in enumerate(BLACKMAN_HARRIS))
    return np.where(np.abs(x) <= width / 2, w, 0.0)


def downsample_taps(k: int) -> tuple[np.ndarray, np.ndarray]:
    """(offsets, weights) along one axis: the sub-pixels of a k-times larger image
    (offsets in its texels from the first sub-pixel of the pixel) that the filter
    reaches from a pixel centre, weights summing to 1."""
    first = -int(np.ceil(FILTER_WIDTH * k - 0.5 * (k - 1)))
    offsets = np.arange(first, k - first)
    centres = (offsets + 0.5) / k - 0.5            # in pixels from the pixel centre
    weights = blackman_harris(centres)
    keep = weights > 0
    return offsets[keep], weights[keep] / weights[keep].sum()


def downsample(image: np.ndarray, k: int) -> np.ndarray:
    """The same filter on the CPU, for render passes read back at the larger size."""
    if k == 1:
        return image
    offsets, weights = downsample_taps(k)
    out = image.astype(np.float64)
    for axis in (0, 1):
        n = out.shape[axis] // k
        idx = np.clip(np.arange(n)[:, None] * k + offsets[None, :], 0, out.shape[axis] - 1)
        out = np.tensordot(np.take(out, idx, axis=axis), weights, axes=([axis + 1], [0]))
    return out.astype(np.float32)


def centre_samples(image: np.ndarray, k: int) -> np.ndarray:
    """The sub-pixel nearest each pixel centre: for render passes that are data
    (depth, normals, indices), which a filter would blend into values no surface has."""
    if k == 1:
        return image
    return np.ascontiguousarray(image[k // 2::k, k // 2::k])


class SupersamplePass(Pass):
    name = "supersample"
    reads = ("hdr",)
    writes = ("hdr",)
    resizes = True      # hdr leaves at the image size, and later passes draw at it

    def __init__(self, ctx, pool, programs):
        self.ctx, self.pool, self.programs = ctx, pool, programs

    def needed(self, frame):
        return frame.supersample > 1

    def execute(self, frame, board):
        ctx, k = self.ctx, frame.supersample
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        big_w, big_h = frame.size
        w, h = frame.output_size
        offsets, weights = downsample_taps(k)
        prog = screen_program(self.programs, "post", ["POST_DOWNSAMPLE"], frame.compute)
        set_uniform(prog, "factor", k)
        set_uniform(prog, "taps", len(offsets))
        taps = np.zeros((MAX_TAPS, 2), np.float32)
        taps[:len(offsets)] = np.stack([offsets, weights], -1)
        set_uniform(prog, "tap", taps)
        source = board["hdr"]
        for axis, size in ((0, (w, big_h)), (1, (w, h))):
            target = self.pool.acquire(size, TARGETS["hdr"])
            source.use(UNITS["post_src"])
            set_uniform(prog, "axis", axis)
            run_screen(ctx, self.programs, self.pool, prog, [target], frame.compute)
            self.pool.release(source)
            source = target
        board["hdr"] = source
        frame.size = (w, h)          # what the passes after this one draw
