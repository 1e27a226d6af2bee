"""The diffuse bounce's cost on the demo (`make demo`'s scene, exported with its
bounces): a frame at 640x360 medium lit directly (bounces 0, today's image) beside the
same frame with the scene's bounces, as a still (a fresh Session: the ray tracer's trees
and the irradiance field built from nothing) and as a steady frame (its field kept).
Prints figures; asserts nothing.

    nice -n 5 .venv/bin/python bench/bench_bounce.py
"""
import pathlib
import platform
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from bench_passes import export_demo  # noqa: E402

from lantern.engine import RenderSettings, Session  # noqa: E402
from lantern.engine.bounces import DIRECT  # noqa: E402

REPEATS = 3


def frames(stage, bounces):
    """(first render's seconds, its field build seconds, best steady seconds, stats)."""
    with Session(stage, RenderSettings(width=640, height=360, preset="medium",
                                       bounces=bounces)) as session:
        session.render()                            # programs made, trees built
    with Session(stage, RenderSettings(width=640, height=360, preset="medium",
                                       bounces=bounces)) as session:
        t0 = time.perf_counter()
        first = session.render()
        still = time.perf_counter() - t0
        steady = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            session.render()
            steady.append(time.perf_counter() - t0)
    return still, first.timings.get("field_build", 0.0), min(steady), first.stats


def main():
    from pxr import Usd
    with tempfile.TemporaryDirectory() as folder:
        stage = Usd.Stage.Open(export_demo(folder))
        print(f"{time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, demo at 640x360 medium")
        for label, bounces in (("direct (bounces 0)", DIRECT), ("scene's bounces", None)):
            still, build, steady, stats = frames(stage, bounces)
            print(f"{label}: still {still:.2f} s (field {build:.2f} s, "
                  f"{stats.get('field_probes', 0)} probes, {stats.get('field_rays', 0)} rays), "
                  f"steady frame {steady:.3f} s")


if __name__ == "__main__":
    main()
