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
edges move, and off them the image is the separable filter's. Light render passes,
filtered on the CPU, take the same marks (downsample).

reads: hdr (k x the image size), g_depth, edge_depth (optional)
writes: hdr (the image size; later passes draw at it); edge_marks (read back, for the
        render passes, in frames that ask for light passes)
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
    """Whether render pass `name`, read back at a supersampled size, is light filtered
    as the image is (downsample): not data (centre_samples), nor a matte (Cryptomatte
    ranks its own sub-pixels)."""
    return not PASSES[name].matte and name not in DATA_PASSES
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


def downsample(image: np.ndarray, k: int, edges=None) -> np.ndarray:
    """The same filter on the CPU, for render passes read back at the larger size (row
    0 = top); `edges`: the frame's edge samples (SupersamplePass hands them on as
    board["edge_marks"]), whose gather the filter then does as the image's did."""
    if k == 1:
        return image
    offsets, weights = downsample_taps(k)
    out = image.astype(np.float64)
    for axis in (0, 1):
        n = out.shape[axis] // k
        idx = np.clip(np.arange(n)[:, None] * k + offsets[None, :], 0, out.shape[axis] - 1)
        out = np.tensordot(np.take(out, idx, axis=axis), weights, axes=([axis + 1], [0]))
    if edges is not None:
        out = _edge_gather(image, out, k, *edges)
    return out.astype(np.float32)


def _edge_gather(image, separable, k, marks, sample_at):
    """shaders/edge_samples.glsl EDGE_GATHER on the CPU: `separable` with each crossed
    cell (`marks`, EDGE_MARK's output as GL holds it, row 0 = bottom) within a pixel's
    reach taken out at its centre and put in as its samples."""
    big, sep = image[::-1].astype(np.float64), separable[::-1]     # GL's rows, as the marks
    first, centre, at_x, at_y = edge_taps(k, sample_at)
    n = len(centre)
    (hk, wk), (h, w) = marks.shape, sep.shape[:2]
    # Crossed cells, and the places beyond the border that read them (the filter's
    # cells are clamped to the image).
    vy, vx = np.nonzero(np.pad(marks, n, mode="edge"))
    vy, vx = vy - n, vx - n
    cy, cx = np.clip(vy, 0, hk - 1), np.clip(vx, 0, wk - 1)
    code = marks[cy, cx].astype(np.int64) - 1
    taken = [big[cy + f // 3 - 1, cx + f % 3 - 1]                   # each sample's colour
             for f in ((code >> (4 * s)) & 15 for s in range(4))]
    add, total = np.zeros_like(sep), np.zeros(sep.shape[:2])
    # A cell is the i-th of pixel p's reach where k p + first + i is its place.
    for my in range(3):
        j = (vy - first) % k + my * k
        py = (vy - first - j) // k
        for mx in range(3):
            i = (vx - first) % k + mx * k
            px = (vx - first - i) // k
            ok = (i < n) & (j < n) & (px >= 0) & (px < w) & (py >= 0) & (py < h)
            ii, jj, at = i[ok], j[ok], (py[ok], px[ok])
            own = centre[ii] * centre[jj]
            quarter = 0.25 * at_x[ii] * at_y[jj]
            np.add.at(add, at, sum(quarter[:, s, None] * taken[s][ok] for s in range(4))
                      - own[:, None] * big[cy[ok], cx[ok]])
            np.add.at(total, at, quarter.sum(1) - own)
    return ((sep + add) / (1.0 + total)[..., None])[::-1]


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
        image = source = board["hdr"]
        for axis, size in ((0, (w, big_h)), (1, (w, h))):
            target = self.pool.acquire(size, TARGETS["hdr"])
            source.use(UNITS["post_src"])
            set_uniform(prog, "axis", axis)
            run_screen(ctx, self.programs, self.pool, prog, [target], frame.compute)
            if source is not image:
                self.pool.release(source)
            source = target
        if "edge_depth" in board and self._sample_places(board["edge_depth"]):
            source = self._edges(frame, board, image, source)
        self.pool.release(image)
        board["hdr"] = source
        frame.size = (w, h)          # what the passes after this one draw

    def _sample_places(self, edge_depth) -> bool:
        """Whether the driver gave edge_depth four samples a texel (it may give more
        than asked for; the filter then keeps to the sub-pixels), their places kept."""
        if self._sample_at is None:
            self._sample_at = self.depth.sample_positions(self.pool.framebuffer(depth=edge_depth))
        return len(self._sample_at) == 4

    def _edges(self, frame, board, image, separable):
        """EDGE_MARK at the sub-pixels, then EDGE_GATHER at the pixels (module
        docstring): the image with its edges where the edge samples put them.
        `separable` is given back."""
        ctx, compute = self.ctx, frame.compute
        edge_depth = board["edge_depth"]
        marks = self.pool.acquire(image.size, "r32f")
        prog = screen_program(self.programs, "edge_samples", ["EDGE_MARK"], compute)
        board["g_depth"].use(UNITS["g_depth"])
        edge_depth.use(UNITS["edge_depth"])
        run_screen(ctx, self.programs, self.pool, prog, [marks], compute)
        pixels = self.pool.acquire(separable.size, "r32f")
        prog = screen_program(self.programs, "edge_samples", ["EDGE_PIXELS"], compute)
        set_uniform(prog, "factor", frame.supersample)
        marks.use(UNITS["edge_marks"])
        run_screen(ctx, self.programs, self.pool, prog, [pixels], compute)
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
        run_screen(ctx, self.programs, self.pool, prog, [out], compute)
        if any(filtered(name) for name in frame.aovs):
            # Light render passes are filtered on the CPU after the frame (downsample):
            # they take their edges from the same marks.
            board["edge_marks"] = (np.frombuffer(marks.read(), np.float32).reshape(
                marks.height, marks.width), np.asarray(self._sample_at))
        self.pool.release(pixels)
        self.pool.release(marks)
        self.pool.release(separable)
        return out
