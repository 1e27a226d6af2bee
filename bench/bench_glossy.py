"""The glossy bounce's cost on the demo (`make demo`'s scene): steady frames at 640x360
medium lit directly (bounces 0), with the diffuse bounce only (glossy bounces 0) and with
both (the scene's Cycles defaults), the three Sessions' frames interleaved so that the
machine's load falls on each alike; and the reflection pass's own GPU seconds. Prints
figures; asserts nothing.

    nice -n 5 .venv/bin/python bench/bench_glossy.py
"""
import pathlib
import platform
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from bench_passes import export_demo  # noqa: E402

from lantern.engine import RenderSettings, Session  # noqa: E402
from lantern.engine.bounces import DIRECT, Bounces  # noqa: E402

REPEATS = 5
CASES = (("direct (bounces 0)", DIRECT), ("diffuse bounce only", Bounces(12, 4, 0)),
         ("diffuse and glossy bounces", Bounces(12, 4, 4)))


def main():
    from pxr import Usd
    with tempfile.TemporaryDirectory() as folder:
        stage = Usd.Stage.Open(export_demo(folder))
        sessions = [(label, Session(stage, RenderSettings(width=640, height=360, preset="medium",
                                                          bounces=bounces)))
                    for label, bounces in CASES]
        try:
            for _, session in sessions:
                session.render()                    # programs made, trees and field built
            seconds = {label: [] for label, _ in CASES}
            gpu = {}
            for _ in range(REPEATS):
                for label, session in sessions:
                    t0 = time.perf_counter()
                    result = session.render()
                    seconds[label].append(time.perf_counter() - t0)
                    gpu[label] = result.gpu_timings
        finally:
            for _, session in sessions:
                session.close()
    print(f"{time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, demo at 640x360 medium, "
          f"steady frames, best and median of {REPEATS}")
    for label, times in seconds.items():
        times = sorted(times)
        print(f"{label}: {times[0]:.3f} s, median {times[len(times) // 2]:.3f} s; "
              f"reflections pass {gpu[label].get('reflections', 0.0):.3f} s (GPU)")


if __name__ == "__main__":
    main()
