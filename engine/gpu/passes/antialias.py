"""Anti-aliasing of the deferred image (a G-buffer cannot be multisampled: docs/design.md,
Deferred shading).

  supersample k > 1   (the presets high and ultra, for F12 and the command line) the
                      frame is drawn k times wider and taller, and this pass filters
                      it down with Cycles' pixel filter: Blackman-Harris reaching
                      1.5 px either side of each pixel centre (Cycles doubles the
                      user's 1.5 px width for this filter, scene/film.cpp
                      filter_table), separably, in two draws. A texture lookup
                      filters its sub-pixel (shaders/material.glsl sample_map).
                      With the preset's edge samples, geometric edges are placed
                      by them (below).
  k = 1               FXAA at geometric edges (passes/post.py), when the preset asks;
                      texture lookups filter with the same pixel filter
                      (BLACKMAN_HARRIS, FILTER_WIDTH: material.glsl sample_map).

Chosen by measurement (bench/bench_antialias.py, docs/rendering.md "Anti-aliasing"): against
jittered accumulation of as many drawings (a still's TAA) supersampling had the lower
error on every corpus scene at every sample count and took less time, since one
drawing of k^2 pixels costs less than k^2 drawings, and its filter reaches the
neighbouring pixels' samples as Cycles' does.

Edge samples. A grid of sub-pixels puts an edge along the pixel rows or columns on the
nearest line between sub-pixel centres: up to a quarter of a pixel off at 2x2, as far
as one sample a pixel puts it, where Cycles' filter, fed by samples everywhere, puts it
where it lies (docs/compare.md). So the G-buffer pass draws the geometry's depth again,
multisampled, at four places in every sub-pixel (edge_depth), and three screen passes
follow the separable filter (shaders/edge_samples.glsl): EDGE_MARK names, for each
sub-pixel with a sample on another surface than its centre's, the neighbouring
sub-pixel each sample takes its colour from; EDGE_PIXELS marks the pixels holding one;
EDGE_GATHER, near those, takes each such sub-pixel out of the filter at its centre and
puts it back in as its samples, each at its place. Shading stays once a sub-pixel; only
edges move, and off them the image is the separable filter's.

Render passes of light (filtered) go through the same reduction, marks included, so
they add up to the image as they did at k = 1; data passes keep their centre
sub-pixel (centre_samples, after the read-back).

reads: hdr (k x the image size), g_depth, edge_depth (optional), the frame's filtered
       render-pass targets
writes: hdr and those targets, at the image size (later passes draw at it)
"""
from __future__ import annotations

import numpy as np

from ....core.passes import PASSES
from ..framegraph import TARGETS, Pass
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program

FILTER_WIDTH = 1.5          # pixels, Cycles' default (Film > Pixel Filter > Width)
# Render passes that are data, not light: never filtered (centre_samples).
DATA_PASSES = {"Depth", "Normal", "IndexOB", "IndexMA"}


def filtered(name: str) -> bool:
    """Whether render pass `name`, drawn at a supersampled size, is light, filtered as
    the image is (SupersamplePass): not data (centre_samples), nor a matte (Cryptomatte
    ranks its own sub-pixels)."""
    return not PASSES[name].matte and name not in DATA_PASSES


def filtered_targets(frame) -> tuple:
    """The targets of the frame's filtered render passes, as the graph names them
    (Frame.aov_targets); their passes all run before the reduction."""
    return tuple(sorted({frame.aov_targets[name][0] for name in frame.aovs
                         if filtered(name)}))


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


def edge_taps(k: int, sample_at) -> tuple:
    """The filter's weights for EDGE_GATHER (shaders/edge_samples.glsl) along one axis
    of a k-times larger image: (first, centre (n,), at_x (n, 4), at_y (n, 4)). Cell i is
    k * pixel + first + i; `centre` weighs its centre, as downsample_taps does, and
    at_x, at_y each sample's place in it (`sample_at`, (4, 2), in [0, 1)), all over
    downsample_taps' sum so a pixel's weights keep summing to 1."""
    offsets, _ = downsample_taps(k)
    span = np.arange(offsets[0] - 1, offsets[-1] + 2)
    norm = blackman_harris((offsets + 0.5) / k - 0.5).sum()
    centre = blackman_harris((span + 0.5) / k - 0.5) / norm
    at = [blackman_harris((span[:, None] + np.asarray(sample_at)[None, :, axis]) / k - 0.5) / norm
          for axis in (0, 1)]
    keep = (centre > 0) | (at[0] > 0).any(1) | (at[1] > 0).any(1)
    return int(span[keep][0]), centre[keep], at[0][keep], at[1][keep]


def centre_samples(image: np.ndarray, k: int) -> np.ndarray:
    """The sub-pixel nearest each pixel centre: for render passes that are data
    (depth, normals, indices), which a filter would blend into values no surface has."""
    if k == 1:
        return image
    return np.ascontiguousarray(image[k // 2::k, k // 2::k])


class SupersamplePass(Pass):
    name = "supersample"
    reads = ("hdr", "g_depth")
    optional = ("edge_depth",)
    writes = ("hdr",)
    resizes = True      # hdr leaves at the image size, and later passes draw at it

    def __init__(self, ctx, pool, programs, depth):
        self.ctx, self.pool, self.programs, self.depth = ctx, pool, programs, depth
        self._sample_at = None      # the driver's places of four samples (depth.py)

    def needed(self, frame):
        return frame.supersample > 1

    def execute(self, frame, board):
        self.ctx.disable(self.ctx.BLEND | self.ctx.DEPTH_TEST | self.ctx.CULL_FACE)
        edges = None
        if "edge_depth" in board and self._sample_places(board["edge_depth"]):
            edges = self._edge_marks(frame, board)
        for name in ("hdr",) + filtered_targets(frame):
            board[name] = self._reduce(frame, board[name], edges)
        for texture in edges or ():
            self.pool.release(texture)
        frame.size = frame.output_size          # what the passes after this one draw

    def _reduce(self, frame, image, edges):
        """`image` (given back) filtered to the image size: separably, then with the
        edge samples' gather where `edges` (EDGE_MARK's and EDGE_PIXELS' targets)."""
        k, compute = frame.supersample, frame.compute
        (w, h), big_h = frame.output_size, image.size[1]
        offsets, weights = downsample_taps(k)
        prog = screen_program(self.programs, "post", ["POST_DOWNSAMPLE"], compute)
        set_uniform(prog, "factor", k)
        set_uniform(prog, "taps", len(offsets))
        taps = np.zeros((MAX_TAPS, 2), np.float32)
        taps[:len(offsets)] = np.stack([offsets, weights], -1)
        set_uniform(prog, "tap", taps)
        source = image
        for axis, size in ((0, (w, big_h)), (1, (w, h))):
            target = self.pool.acquire(size, TARGETS["hdr"])
            source.use(UNITS["post_src"])
            set_uniform(prog, "axis", axis)
            run_screen(self.ctx, self.programs, self.pool, prog, [target], compute)
            if source is not image:
                self.pool.release(source)
            source = target
        if edges is not None:
            source = self._gather(frame, image, source, *edges)
        self.pool.release(image)
        return source

    def _sample_places(self, edge_depth) -> bool:
        """Whether the driver gave edge_depth four samples a texel (it may give more
        than asked for; the filter then keeps to the sub-pixels), their places kept."""
        if self._sample_at is None:
            self._sample_at = self.depth.sample_positions(self.pool.framebuffer(depth=edge_depth))
        return len(self._sample_at) == 4

    def _edge_marks(self, frame, board) -> tuple:
        """(EDGE_MARK at the sub-pixels, EDGE_PIXELS at the pixels): the targets the
        gather of every reduction this frame reads (module docstring)."""
        ctx, compute = self.ctx, frame.compute
        marks = self.pool.acquire(frame.size, "r32f")
        prog = screen_program(self.programs, "edge_samples", ["EDGE_MARK"], compute)
        board["g_depth"].use(UNITS["g_depth"])
        board["edge_depth"].use(UNITS["edge_depth"])
        run_screen(ctx, self.programs, self.pool, prog, [marks], compute)
        pixels = self.pool.acquire(frame.output_size, "r32f")
        prog = screen_program(self.programs, "edge_samples", ["EDGE_PIXELS"], compute)
        set_uniform(prog, "factor", frame.supersample)
        marks.use(UNITS["edge_marks"])
        run_screen(ctx, self.programs, self.pool, prog, [pixels], compute)
        return marks, pixels

    def _gather(self, frame, image, separable, marks, pixels):
        """EDGE_GATHER: `separable` (given back) with the image's edges where the
        edge samples put them."""
        compute = frame.compute
        out = self.pool.acquire(separable.size, TARGETS["hdr"])
        first, centre, at_x, at_y = edge_taps(frame.supersample, self._sample_at)
        # The cells a pixel's filter reaches along each axis, a constant of the
        # program, so its loops unroll.
        prog = screen_program(self.programs, "edge_samples",
                              ["EDGE_GATHER", f"CELLS {len(centre)}"], compute)
        set_uniform(prog, "factor", frame.supersample)
        set_uniform(prog, "first", first)
        for name, value in (("centre_weight", centre), ("sample_weight_x", at_x),
                            ("sample_weight_y", at_y)):
            set_uniform(prog, name, np.float32(value))
        image.use(UNITS["post_src"])
        marks.use(UNITS["edge_marks"])
        pixels.use(UNITS["edge_pixels"])
        separable.use(UNITS["separable"])
        run_screen(self.ctx, self.programs, self.pool, prog, [out], compute)
        self.pool.release(separable)
        return out

