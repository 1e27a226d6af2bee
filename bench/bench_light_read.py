"""Reading many light prims: 16,384 small point lights (bench_gpu.py's many-lights
scene, authored as Sdf specs), read by the engine's stage reader.

Prints the CPU seconds of the stage read (StageReader's first sync; each run a new
reader on the same stage); the floor under it from Python: the USD calls a light's
record cannot do without (traversal, visibility, type, its authored inputs' values,
its world transform), made alone with nothing done with what they return; a
Session's first render minus its warm render (wall seconds, 160x90 medium: the read,
the light table and the first frame's upload); and with --profile the stage read's
cProfile (CPU time), by own time. CPU seconds, not wall: machines shared with other
work inflate wall time most.

    .venv/bin/python bench/bench_light_read.py [--count 16384] [--runs 5] [--profile]
"""
import argparse
import cProfile
import pathlib
import pstats
import statistics
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))

from bench_gpu import lights_stage  # noqa: E402


def stage_read(stage, runs):
    from lantern.engine.usd.stage import StageReader
    seconds = []
    for _ in range(runs):
        reader = StageReader(stage)
        start = time.process_time()
        reader.sync(None)
        seconds.append(time.process_time() - start)
        reader.close()
    return seconds


def usd_floor(stage, runs):
    """The USD calls of a light's read alone (see the module's docstring)."""
    from pxr import Usd, UsdGeom, UsdLux
    from lantern.engine.usd.lights import INPUTS
    seconds = []
    for _ in range(runs):
        start = time.process_time()
        cache = UsdGeom.XformCache(Usd.TimeCode.Default())
        for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()):
            prim.IsAbstract()
            UsdGeom.Imageable(prim).GetVisibilityAttr().HasAuthoredValue()
            str(prim.GetPath())
            if prim.IsA(UsdGeom.Gprim) or not prim.HasAPI(UsdLux.LightAPI):
                continue
            prim.GetTypeName()
            for attr in prim.GetAuthoredAttributes():
                if attr.GetName() in INPUTS:
                    attr.Get()
            cache.GetLocalToWorldTransform(prim)
        seconds.append(time.process_time() - start)
    return seconds


def first_minus_warm(stage, runs):
    from lantern.engine import RenderSettings, Session
    out = []
    for _ in range(runs):
        with Session(stage, RenderSettings(width=160, height=90, preset="medium")) as session:
            start = time.perf_counter()
            session.render()
            first = time.perf_counter() - start
            start = time.perf_counter()
            session.render()
            out.append(first - (time.perf_counter() - start))
    return out


def profile(stage, rows=25):
    from lantern.engine.usd.stage import StageReader
    reader = StageReader(stage)
    prof = cProfile.Profile(time.process_time)
    prof.enable()
    reader.sync(None)
    prof.disable()
    pstats.Stats(prof).sort_stats("tottime").print_stats(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=16384)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--profile", action="store_true")
    args = ap.parse_args()
    stage = lights_stage(args.count)
    read = stage_read(stage, args.runs)
    print(f"{args.count} lights: stage read {statistics.median(read):.2f} CPU s median "
          f"(min {min(read):.2f}, max {max(read):.2f}, {args.runs} runs)")
    floor = usd_floor(stage, args.runs)
    print(f"  the USD calls alone: {statistics.median(floor):.2f} CPU s median "
          f"(min {min(floor):.2f}, max {max(floor):.2f})")
    session = first_minus_warm(stage, max(1, args.runs // 2))
    print(f"  Session first render minus warm render: {statistics.median(session):.2f} s "
          f"median (min {min(session):.2f}, max {max(session):.2f})")
    if args.profile:
        profile(stage)


if __name__ == "__main__":
    main()
