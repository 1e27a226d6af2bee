"""Wall time of each pass and each compute dispatch of a warm frame, with glFinish on
both sides of each, so that nothing overlaps it: where the frame graph's timestamps
(bench_gpu.py) blur the gaps a driver leaves between passes, this says which step
costs. Each step's time is split in two: the CPU's, until the step's calls return
(Python, and the driver's own work at the call: a recompile, an allocation, a wait it
makes), and the wait in glFinish after them (the GPU's work, and what the driver
deferred to it). llvmpipe runs a compute dispatch within its call, so there it is all
CPU. Scenes from `bench_gpu.py prepare`.

    python bench/bench_dispatches.py .gpu/scenes lights_1 lights_16384 demo --size 1920x1080
"""
from __future__ import annotations

import argparse
import pathlib
import statistics
import time

import moderngl
import numpy as np


def timed_steps(folder, name, size, preset, frames=3) -> dict:
    """{step: (median ms, median ms of CPU, median ms waiting)}: each pass ("pass"),
    each dispatch ("pass: dispatch (x, y)")."""
    from lantern.engine import RenderSettings, Session
    from lantern.engine.gpu import framegraph
    from lantern.engine.usd.opening import open_stage
    log, current = {}, [""]

    def finished(ctx, label, fn, *args, **kw):
        ctx.finish()
        t0 = time.perf_counter()
        out = fn(*args, **kw)
        t1 = time.perf_counter()
        ctx.finish()
        t2 = time.perf_counter()
        log.setdefault(label, []).append(((t2 - t0) * 1e3, (t1 - t0) * 1e3, (t2 - t1) * 1e3))
        return out

    dispatch, run = moderngl.ComputeShader.run, framegraph.FrameGraph.run

    def timed_dispatch(self, *groups, **kw):
        return finished(self.ctx, f"{current[0]}: dispatch {groups}", dispatch, self, *groups, **kw)

    def timed_run(graph, frame, plan=None):
        for p in graph.passes:
            if "execute" not in vars(p):
                def execute(frame, board, p=p, step=type(p).execute):
                    current[0] = p.name
                    return finished(graph.ctx, p.name, step, p, frame, board)
                p.execute = execute
        return run(graph, frame, plan)

    moderngl.ComputeShader.run, framegraph.FrameGraph.run = timed_dispatch, timed_run
    try:
        settings = RenderSettings(width=size[0], height=size[1], preset=preset, compute=True)
        with Session(open_stage(str(folder / f"{name}.usdc")), settings) as session:
            out = np.zeros((size[1], size[0], 4), np.float32)
            for _ in range(2):
                session.render(out=out)
            log.clear()
            for _ in range(frames):
                session.render(out=out)
    finally:
        moderngl.ComputeShader.run, framegraph.FrameGraph.run = dispatch, run
    return {k: tuple(statistics.median(column) for column in zip(*v)) for k, v in log.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=pathlib.Path)
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--preset", default="medium")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    for name in args.scenes:
        steps = timed_steps(args.folder, name, size, args.preset)
        print(f"{name} {args.size} {args.preset}, ms (glFinish around each step): "
              f"all = CPU until the calls return + wait in glFinish")
        for label, (ms, cpu, wait) in sorted(steps.items(), key=lambda kv: -kv[1][0]):
            if ms >= 0.05:
                print(f"  {ms:8.2f} = {cpu:7.2f} + {wait:7.2f}  {label}")


if __name__ == "__main__":
    main()
