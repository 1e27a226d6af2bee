"""The read-back against one bare glReadPixels: what the engine's read of an RGBA image
(engine/gpu/readback.py) costs in each read mode (direct: glReadPixels into the
caller's memory; mapped: into a persistently mapped pixel buffer, then one memcpy),
into a caller's reused buffer and into a new array, float32 and half floats, at
640x360, 1920x1080 and 3840x2160. Prints a table; asserts nothing.

    python bench/bench_readback.py [--sizes 640x360 ...] [--runs N] [--json F]

"bare" is ModernGL's Framebuffer.read_into (one glReadPixels) into a reused numpy
array, the floor; "bare, new" the same into a new array every time (the first touch
of its pages). Each figure is the fastest of --runs reads (default 15), each after a
glFinish, so that other work on the machine and earlier GL work add nothing; the
median is printed beside it. Runs without bpy, so also on the GPU machine."""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

import numpy as np

SIZES = {"640x360": (640, 360), "1920x1080": (1920, 1080), "3840x2160": (3840, 2160)}
FORMATS = ("float32", "half")


def measure(gl, size, fmt, runs):
    """{way: [seconds per run]} for one size and format."""
    from lantern.engine.gpu.readback import FORMATS as DTYPES
    from lantern.engine.gpu.readback import MODES, Readback, ReadbackRequest
    ctx, (w, h) = gl.ctx, size
    dtype, np_dtype = DTYPES[fmt]
    texture = ctx.texture((w, h), 4, dtype="f4")
    texture.write(np.random.default_rng(1).random((h, w, 4), np.float32).tobytes())
    fbo = ctx.framebuffer([texture])
    reused = np.empty((h, w, 4), np_dtype)
    reused.fill(0)                                # its pages touched once, before
    ways = {"bare": lambda: fbo.read_into(reused, components=4, dtype=dtype),
            "bare, new": lambda: fbo.read_into(np.empty((h, w, 4), np_dtype), components=4,
                                               dtype=dtype)}
    readers = []
    for mode in MODES:
        if mode == "mapped" and gl.version < 440:
            continue
        rb = Readback(ctx, gl.programs, gl.proc, compute=False, mode=mode)
        readers.append(rb)

        def read(out, rb=rb):
            rb.read(rb.slot(), fbo, size, ReadbackRequest(fmt, out=out))
        ways[f"{mode}, reused"] = lambda read=read: read(reused)
        ways[f"{mode}, new"] = lambda read=read: read(None)
    seconds = {way: [] for way in ways}
    try:
        for _ in range(runs):
            for way, fn in ways.items():      # taking turns: load falls on every way
                ctx.finish()
                t0 = time.perf_counter()
                fn()
                seconds[way].append(time.perf_counter() - t0)
    finally:
        for rb in readers:
            rb.release()
        fbo.release()
        texture.release()
    return seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=list(SIZES), choices=list(SIZES))
    parser.add_argument("--runs", type=int, default=15)
    parser.add_argument("--json")
    args = parser.parse_args()
    from lantern.engine.gpu.context import run_gl
    info = run_gl(lambda gl: gl.describe())
    print(f"GL: {info.get('gl_renderer')}, {info.get('gl_version')}; default read mode "
          f"{os.environ.get('LANTERN_READBACK') or 'the module default'}")
    rows = []
    for size_name in args.sizes:
        for fmt in FORMATS:
            seconds = run_gl(lambda gl: measure(gl, SIZES[size_name], fmt, args.runs))
            row = {"size": size_name, "format": fmt,
                   "min_ms": {k: 1e3 * min(v) for k, v in seconds.items()},
                   "median_ms": {k: 1e3 * statistics.median(v) for k, v in seconds.items()}}
            rows.append(row)
            floor = row["min_ms"]["bare"]
            print(f"{size_name:>9} {fmt:<7} " + " | ".join(
                f"{way} {row['min_ms'][way]:.2f} ({row['median_ms'][way]:.2f})"
                + ("" if way == "bare" else f" {row['min_ms'][way] / floor:.2f}x")
                for way in seconds), flush=True)
    if args.json:
        tmp = f"{args.json}.tmp"
        with open(tmp, "w") as f:
            json.dump({"date": time.strftime("%Y-%m-%d"), "gl": info, "rows": rows}, f, indent=1)
        os.replace(tmp, args.json)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
