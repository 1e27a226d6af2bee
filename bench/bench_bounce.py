"""The diffuse bounce's cost on the demo (`make demo`'s scene, exported with its
bounces): a frame at 640x360 medium lit directly (bounces 0, today's image) beside the
same frame with the scene's bounces, as a still (a fresh Session: the ray tracer's trees
and the irradiance field built from nothing) and as a steady frame (its field kept);
then a viewport's frames after a light moved, with the ray budget a frame
(RenderSettings.progressive_field) and without it (the whole field in the frame):
each frame's time and how many frames the field takes to converge.
Times are wall seconds and, beside them, the process's CPU seconds (llvmpipe's threads
included), which a shared machine disturbs less. Prints figures; asserts nothing.

    nice -n 5 .venv/bin/python bench/bench_bounce.py [--size 1920x1080] [--no-viewport]
"""
import argparse
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


def frames(stage, bounces, size):
    """(first render's seconds and CPU seconds, its field build seconds, best steady
    seconds and CPU seconds, stats): a still, then a viewport's frames of the same view
    (progressive_field: the field kept, no final gather)."""
    settings = RenderSettings(width=size[0], height=size[1], preset="medium", bounces=bounces)
    with Session(stage, settings) as session:
        session.render()                            # programs made, trees built
    with Session(stage, settings) as session:
        t0, c0 = time.perf_counter(), time.process_time()
        first = session.render()
        still, still_cpu = time.perf_counter() - t0, time.process_time() - c0
        # A viewport's steady frame: the field kept, no final gather (a still's).
        session.configure(progressive_field=True)
        steady = []
        for _ in range(REPEATS):
            t0, c0 = time.perf_counter(), time.process_time()
            session.render()
            steady.append((time.perf_counter() - t0, time.process_time() - c0))
    best = min(steady)
    return (still, still_cpu), first.timings.get("field_build", 0.0), best, first.stats


def _nudge(stage):
    """Moves the stage's first light a little (an edit the field depends on)."""
    from pxr import Gf, UsdGeom, UsdLux
    prim = next(p for p in stage.Traverse() if p.HasAPI(UsdLux.LightAPI))
    op = UsdGeom.Xformable(prim).AddTranslateOp(opSuffix="nudge") \
        if not prim.HasAttribute("xformOp:translate:nudge") else \
        UsdGeom.XformOp(prim.GetAttribute("xformOp:translate:nudge"))
    if op.GetOpName() not in UsdGeom.Xformable(prim).GetXformOpOrderAttr().Get():
        order = list(UsdGeom.Xformable(prim).GetXformOpOrderAttr().Get()) + [op.GetOpName()]
        UsdGeom.Xformable(prim).GetXformOpOrderAttr().Set(order)
    old = op.Get() or Gf.Vec3d(0.0)
    op.Set(Gf.Vec3d(old[0] + 0.05, old[1], old[2]))


def viewport(stage, progressive):
    """After a light moved in a converged viewport: (each frame's seconds until the
    field converged, each frame's field rays, each frame's field GPU seconds)."""
    with Session(stage, RenderSettings(width=640, height=360, preset="medium",
                                       progressive_field=progressive)) as session:
        while session.render().stats["field_pending"]:
            pass
        _nudge(stage)
        seconds, rays, field = [], [], []
        for _ in range(100):
            t0 = time.perf_counter()
            result = session.render()
            seconds.append(time.perf_counter() - t0)
            rays.append(result.stats["field_rays"])
            field.append(result.gpu_timings.get("irradiance", 0.0))
            if not result.stats["field_pending"]:
                break
    return seconds, rays, field


def main():
    from pxr import Usd
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default=(640, 360),
                        type=lambda t: tuple(map(int, t.split("x"))))
    parser.add_argument("--no-viewport", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        stage = Usd.Stage.Open(export_demo(folder))
        print(f"{time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, demo at "
              f"{args.size[0]}x{args.size[1]} medium")
        for label, bounces in (("direct (bounces 0)", DIRECT), ("scene's bounces", None)):
            (still, still_cpu), build, (steady, steady_cpu), stats = frames(stage, bounces, args.size)
            print(f"{label}: still {still:.2f} s, CPU {still_cpu:.2f} s (field {build:.2f} s, "
                  f"{stats.get('field_probes', 0)} probes, {stats.get('field_rays', 0)} rays), "
                  f"steady frame {steady:.3f} s, CPU {steady_cpu:.3f} s")
        if args.no_viewport:
            return
        for label, progressive in (("viewport, ray budget", True), ("viewport, no budget", False)):
            seconds, rays, field = viewport(stage, progressive)
            print(f"{label}: after a light moved, {len(seconds)} frame(s) to converge, "
                  f"{max(rays)} rays a frame at most, field GPU {max(field):.3f} s a frame at "
                  f"most, frames {min(seconds):.3f}-{max(seconds):.3f} s "
                  f"(mean {sum(seconds) / len(seconds):.3f} s)")


if __name__ == "__main__":
    main()
