"""What emissive polygons cost as lights (engine/emitters.py): the plane of
tests/emitter_scenes.py lit by a rect light, then by an emissive panel of the same size
and power made of N x N quads (N^2 polygon lights, one shared shadow map), at 320 x 240,
medium, through both forms of the light pass. Prints a Markdown table of the warm frame
(the fastest of WARM frames after one untimed: wall ms, the process's CPU ms, which
counts llvmpipe's threads and is steadier on a shared machine) and its light pass;
asserts nothing.

    nice -n 19 .venv/bin/python bench/bench_emitters.py [N ...]
"""
import pathlib
import platform
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))

from emitter_scenes import FORMS, stage_with  # noqa: E402
from lantern.engine import RenderSettings, Session  # noqa: E402

WARM = 3
SIZE = (320, 240)


def warm_frame(stage, form):
    """(fastest warm frame in ms, its CPU ms, its light passes' GPU ms: lights,
    light_cull, clustered)."""
    session = Session(stage, RenderSettings(width=SIZE[0], height=SIZE[1], preset="medium",
                                            **FORMS[form]))
    try:
        session.render()
        best = None
        for _ in range(WARM):
            t, cpu = time.perf_counter(), time.process_time()
            result = session.render()
            ms = (time.perf_counter() - t) * 1e3
            cpu_ms = (time.process_time() - cpu) * 1e3
            light = 1e3 * sum(result.gpu_timings.get(name, 0.0)
                              for name in ("lights", "light_cull", "clustered"))
            if best is None or cpu_ms < best[1]:
                best = (ms, cpu_ms, light)
        return best
    finally:
        session.close()


def main():
    cells = [int(a) for a in sys.argv[1:]] or [1, 4, 16, 32]
    print(f"Emitters at {SIZE[0]}x{SIZE[1]}, medium; {time.strftime('%Y-%m-%d %H:%M')}, "
          f"{platform.machine()}; warm frame ms / CPU ms (light passes' GPU ms), least CPU "
          f"of {WARM}.")
    print()
    print("| lit by | polygon lights | " + " | ".join(FORMS) + " |")
    print("|---|---|" + "---|" * len(FORMS))
    cases = [("rect light", stage_with("rect"), 0)] + \
        [(f"panel of {n} x {n} quads", stage_with("quad", cells=n), n * n) for n in cells]
    for what, stage, lights in cases:
        row = [warm_frame(stage, form) for form in FORMS]
        print(f"| {what} | {lights} | " + " | ".join(f"{ms:.0f} / {cpu:.0f} ({light:.0f})" for ms, cpu, light in row)
              + " |", flush=True)


if __name__ == "__main__":
    main()
