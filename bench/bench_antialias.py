"""Anti-aliasing, error per millisecond: FXAA, jittered accumulation (the engine's
`samples`) and supersampling (the same scene drawn k times larger in one drawing,
down-sampled with Cycles' pixel filter: Blackman-Harris reaching 1.5 px either side)
on the corpus reference scenes, mean HDR-FLIP against Cycles and the warm render time
(median of 3; supersampling's down-sample runs on the CPU here and is not timed, the
GPU would do it in well under a millisecond). Prints a table; asserts nothing.

    .venv/bin/python bench/bench_antialias.py
"""
import pathlib
import sys
import tempfile
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import reference_scenes  # noqa: E402
from image_metrics import mean_flip  # noqa: E402
from lantern.engine import RenderSettings, Session, read_exr  # noqa: E402
from lantern.engine.gpu.passes.antialias import blackman_harris  # noqa: E402
from lantern.exporters import stage_from_depsgraph  # noqa: E402

SCENES = ["02_suzanne", "01_principled_material", "09_tex_wrapping_mirror", "01_alpha_blend",
          "01_alpha_mask", "demo", "environment_mirror", "cutout_shadow"]
LOOKS = TESTS / "references" / "looks"


def downsample(image, k):
    """A k-times larger image -> its size / k, each pixel the Blackman-Harris weighted
    sum of the sub-pixels within 1.5 px of its centre (Cycles' film filter)."""
    h, w = image.shape[0] // k, image.shape[1] // k
    sub = (np.arange(-2 * k, 3 * k) + 0.5) / k - 0.5     # sub-pixel centres, in pixels
    weights = blackman_harris(sub)
    weights /= weights.sum()
    pad = np.pad(image, ((2 * k, 2 * k), (2 * k, 2 * k), (0, 0)), mode="edge")
    rows = sum(weights[i] * pad[i:i + h * k:k] for i in range(len(sub)))[:h]
    rows = np.pad(rows, ((0, 0), (0, 0), (0, 0)))
    return sum(weights[i] * rows[:, i:i + w * k:k] for i in range(len(sub)))[:, :w]


def timed(stage, settings, frame):
    with Session(stage, settings) as session:
        session.render(frame=frame)
        times = []
        for _ in range(3):
            start = time.perf_counter()
            result = session.render(frame=frame)
            times.append(time.perf_counter() - start)
    return result.rgba, float(np.median(times)) * 1000


def main():
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="lantern-aa-"))
    configs = [("none", dict(samples=1, fxaa=False), 1), ("FXAA", dict(samples=1, fxaa=True), 1)]
    configs += [(f"accumulate {n}", dict(samples=n), 1) for n in (4, 9, 16)]
    configs += [(f"supersample {k}x{k}", dict(samples=1, fxaa=False), k) for k in (2, 3, 4)]
    print(f"{'scene':<24}" + "".join(f"{name:>22}" for name, _, _ in configs))
    for name in SCENES:
        reference_scenes.build(name, workdir)
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        ref = read_exr(str(LOOKS / f"{name}.exr"))
        w, h = reference_scenes.SCENES[name].size
        frame = 13.0 if name == "demo" else None
        row = f"{name:<24}"
        for _, options, k in configs:
            rgba, ms = timed(stage, RenderSettings(width=w * k, height=h * k, preset="medium",
                                                   **options), frame)
            if k > 1:
                rgba = downsample(rgba, k)
            row += f"{mean_flip(rgba, ref):>12.4f} {ms:>7.0f}ms"
        print(row, flush=True)


if __name__ == "__main__":
    main()
