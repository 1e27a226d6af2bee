"""The light accumulation target: float16 against float32, on llvmpipe.

Lights from 1e-6 W to 1e6 W must add up without underflow or Inf:
float16 holds 6e-8..65504 with 11 bits, float32 1e-38..3e38 with 24. An exposure
pre-scale would only move float16's window (a scene with both lights spans 12 orders
of magnitude, float16 about 12 in all, with 3 significant digits). This measures what
float32 costs: the ambient, light and resolve passes (the ones that touch the
target) of the same sessions, alternated, medians. Prints figures, asserts nothing.

    python bench/bench_hdr_target.py
"""
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))

import bench_light_scaling as scaling  # noqa: E402
import session_scenes  # noqa: E402
from lantern.engine import RenderSettings, Session  # noqa: E402
from lantern.engine.gpu import framegraph  # noqa: E402

PASSES = ("ambient", "lights", "resolve")


def scenes():
    rng = np.random.default_rng(0)
    small = [((x, y, 0.3), 0.002) for x, y in rng.uniform(-10, 10, (256, 2))]
    yield "256 small point lights, 640x360", scaling.stage_with_lights(small), (640, 360)
    yield "1 point light, 640x360", scaling.stage_with_lights([((0, 0, 3), 100.0)]), (640, 360)
    yield ("1,000 cubes, 2 shadowed lights, 320x180",
           session_scenes.cubes_stage(1000, lights=("point", "spot")), (320, 180))


def pass_time(stage, size, fmt, runs=9):
    framegraph.TARGETS["hdr"] = fmt
    with Session(stage, RenderSettings(width=size[0], height=size[1])) as session:
        session.render()
        session.render()
        times = []
        for _ in range(runs):
            timings = session.render().gpu_timings
            times.append(sum(timings.get(p, 0.0) for p in PASSES))
    return float(np.median(times)) * 1e3


def main():
    default = framegraph.TARGETS["hdr"]
    try:
        for name, stage, size in scenes():
            times = {"rgba16f": [], "rgba32f": []}
            for _ in range(5):                       # alternated: the machine's load drifts
                for fmt in times:
                    times[fmt].append(pass_time(stage, size, fmt))
            f16, f32 = np.median(times["rgba16f"]), np.median(times["rgba32f"])
            print(f"{name}: ambient + lights + resolve, float16 {f16:.1f} ms, "
                  f"float32 {f32:.1f} ms: ratio {f32 / f16:.2f}")
    finally:
        framegraph.TARGETS["hdr"] = default


if __name__ == "__main__":
    main()
