"""The steady frame's cost with the bounce on the demo (`make demo`'s scene): one
Session per mode at 640x360 medium, lit directly (bounces 0) and with the scene's
bounces, each rendered until its field is built (a viewport's steady frame), then
steady frames interleaved so that the machine's load falls on each alike. Times are
CPU seconds of the process (time.process_time: llvmpipe's threads are the process's),
best and median; beside them each pass's GPU seconds in the best frame. Prints the
ratio of the best frames and the median of each round's (the two rendered back to
back); asserts nothing.

    nice -n 5 .venv/bin/python bench/bench_steady.py [REPEATS]
"""
import os
import pathlib
import platform
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from bench_passes import export_demo  # noqa: E402

from lantern.engine import RenderSettings, Session  # noqa: E402
from lantern.engine.bounces import DIRECT  # noqa: E402

CASES = (("direct", DIRECT), ("bounce", None))


def steady_frames(stage, repeats):
    """{label: [(cpu seconds, gpu_timings)] of each steady frame}."""
    sessions = [(label, Session(stage, RenderSettings(width=640, height=360, preset="medium",
                                                      progressive_field=True,
                                                      bounces=bounces)))
                for label, bounces in CASES]
    try:
        for _, session in sessions:
            while session.render().stats.get("field_pending"):
                pass                                # programs made, trees and field built
        frames = {label: [] for label, _ in CASES}
        for _ in range(repeats):
            for label, session in sessions:
                t0 = time.process_time()
                result = session.render()
                frames[label].append((time.process_time() - t0, result.gpu_timings))
        return frames
    finally:
        for _, session in sessions:
            session.close()


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 4
    from pxr import Usd
    with tempfile.TemporaryDirectory() as folder:
        stage = Usd.Stage.Open(os.environ.get("DEMO_USD") or export_demo(folder))
        frames = steady_frames(stage, repeats)
    print(f"{time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.1f}; demo at 640x360 medium, steady frames, "
          f"CPU seconds, best and median of {repeats}")
    best = {}
    for label, runs in frames.items():
        runs = sorted(runs, key=lambda run: run[0])
        best[label] = runs[0]
        print(f"{label}: {runs[0][0]:.3f} s, median {runs[len(runs) // 2][0]:.3f} s")
    # Each round renders the two back to back: their ratio sees one load.
    rounds = sorted(b[0] / d[0] for d, b in zip(frames["direct"], frames["bounce"]))
    print(f"ratio: {best['bounce'][0] / best['direct'][0]:.2f}x by the best, "
          f"{rounds[len(rounds) // 2]:.2f}x the median round")
    names = sorted(set(best["direct"][1]) | set(best["bounce"][1]),
                   key=lambda n: -best["bounce"][1].get(n, 0.0))
    print(f"{'pass (GPU s, best frame)':28s} {'direct':>8s} {'bounce':>8s}")
    for name in names:
        print(f"{name:28s} {best['direct'][1].get(name, 0.0):8.3f} "
              f"{best['bounce'][1].get(name, 0.0):8.3f}")
    print(f"{'sum':28s} {sum(best['direct'][1].values()):8.3f} "
          f"{sum(best['bounce'][1].values()):8.3f}")


if __name__ == "__main__":
    main()
