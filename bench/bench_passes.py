"""Render passes: what asking for them costs, against the same frame without them, in
the same run, on the demo scene (frame 13) at 640x360 and 1920x1080, medium and ultra.

Per case: the warm frame's time (the best of 5), its ratio to Combined alone, the
Cryptomatte pass's GPU time, and writing the file: a plain RGBA EXR against the
multi-layer EXR of every pass (engine/image_io.py write_layers).

    .venv/bin/python bench/bench_passes.py [--quick]    # --quick: 640x360 only

On a GPU machine the same command gives the GPU's figures (docs/gpu.md: the device
tool runs it as is)."""
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))

from lantern.core.passes import options, provided       # noqa: E402

MATTES = frozenset(n for o in ("crypto_object", "crypto_material", "crypto_asset")
                   for n in options()[o])
CASES = (("Combined only", frozenset()),
         ("Cryptomatte (3 mattes)", MATTES),
         ("every pass", frozenset(p.name for p in provided())))


def export_demo(folder):
    """The demo scene exported, in a Blender subprocess (this process never loads bpy)."""
    blend, usd = os.path.join(folder, "demo.blend"), os.path.join(folder, "demo.usdc")
    code = ("import lantern.exporters\nfrom lantern.demo.build_scene import build\n"
            f"build({blend!r})\n")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "lantern", "export", blend, "-o", usd], check=True,
                   capture_output=True)
    return usd


def _interleaved(session, cases, repeats=5):
    """{label: (best seconds, last result)}: the cases rendered in turn, `repeats`
    rounds, so that a busy machine slows them alike."""
    best = {}
    for _ in range(repeats):
        for label, passes in cases:
            session.configure(passes=passes)
            t0 = time.perf_counter()
            result = session.render()
            seconds = time.perf_counter() - t0
            if label not in best or seconds < best[label][0]:
                best[label] = (seconds, result)
    return best


def _best(fn, repeats=3):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(quick=False):
    from lantern.engine import RenderSettings, Session
    from lantern.engine.image_io import write_image, write_layers
    from lantern.engine.usd.opening import open_stage
    with tempfile.TemporaryDirectory() as folder:
        stage = open_stage(export_demo(folder))
        sizes = ((640, 360),) if quick else ((640, 360), (1920, 1080))
        for width, height in sizes:
            for preset in ("medium", "ultra"):
                with Session(stage, RenderSettings(width=width, height=height, preset=preset,
                                                   frame=13)) as session:
                    for _, passes in CASES:                     # programs, uploads
                        session.configure(passes=passes)
                        session.render()
                    best = _interleaved(session, CASES)
                base = best[CASES[0][0]][0]
                for label, _ in CASES:
                    seconds, result = best[label]
                    crypto = result.gpu_timings.get("cryptomatte", 0.0)
                    print(f"{width}x{height} {preset:6s} {label:24s} "
                          f"{seconds * 1000:8.1f} ms ({seconds / base:.2f}x), "
                          f"Cryptomatte pass GPU {crypto * 1000:.1f} ms")
                path = os.path.join(folder, "out.exr")
                plain = _best(lambda: write_image(path, result.rgba))
                layered = _best(lambda: write_layers(path, result.rgba, result.passes,
                                                     cryptomatte=result.cryptomatte))
                print(f"{width}x{height} {preset:6s} write: plain EXR {plain * 1000:.1f} ms, "
                      f"{len(result.passes)} passes {layered * 1000:.1f} ms "
                      f"({os.path.getsize(path) / 1e6:.1f} MB)")


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
