"""Shadow quality's cost: the demo scene (frame 13: a sun, a point light, a spot and a
2 m area light, every one casting) at 640x360, medium, warm frames, the best of 7, and
each pass's GPU time (result.gpu_timings: the lights' pass reads the shadow maps).

    PYTHONPATH=<folder holding lantern> python bench/bench_shadow_quality.py

Run it on two checkouts (before and after a change) for docs/rendering.md's figures."""
import tempfile
import time

from bench_passes import export_demo   # the demo exported, in Blender subprocesses


def main(repeats=7):
    from lantern.engine import RenderSettings, Session
    from lantern.engine.usd.opening import open_stage
    with tempfile.TemporaryDirectory() as folder:
        stage = open_stage(export_demo(folder))
        settings = RenderSettings(width=640, height=360, preset="medium", frame=13)
        with Session(stage, settings) as session:
            session.render()                            # programs, uploads, maps
            best, passes = None, {}
            for _ in range(repeats):
                t0 = time.perf_counter()
                result = session.render()
                seconds = time.perf_counter() - t0
                if best is None or seconds < best:
                    best = seconds
                for name, t in result.gpu_timings.items():
                    passes[name] = min(passes.get(name, t), t)
    print(f"demo, 640x360 medium, warm frame (best of {repeats}): {best * 1e3:.1f} ms")
    for name in sorted(passes):
        print(f"  {name}: {passes[name] * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
