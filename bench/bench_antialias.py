"""Anti-aliasing, error per millisecond on the corpus reference scenes: none, FXAA,
and supersampling k x k (the engine's `supersample`: drawn k times wider and taller,
filtered down on the GPU with Cycles' pixel filter, Blackman-Harris reaching 1.5 px
either side), at the medium preset otherwise; mean HDR-FLIP against Cycles and the
warm render time (median of 3). Prints a table; asserts nothing.

Jittered accumulation (a still's TAA: k x k drawings with sub-pixel offsets, averaged
with the same filter) was measured with this script at commit a9b91f4, where the
engine had it as `samples`, before supersampling replaced it (docs/rendering.md, "Anti-aliasing").

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
from lantern.exporters import stage_from_depsgraph  # noqa: E402

SCENES = ["02_suzanne", "01_principled_material", "09_tex_wrapping_mirror", "01_alpha_blend",
          "01_alpha_mask", "demo", "environment_mirror", "cutout_shadow"]
LOOKS = TESTS / "references" / "looks"


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
    configs = [("none", dict(supersample=1, fxaa=False)), ("FXAA", dict(supersample=1, fxaa=True))]
    configs += [(f"supersample {k}x{k}", dict(supersample=k)) for k in (2, 3, 4)]
    print(f"{'scene':<24}" + "".join(f"{name:>22}" for name, _ in configs))
    for name in SCENES:
        reference_scenes.build(name, workdir)
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        ref = read_exr(str(LOOKS / f"{name}.exr"))
        w, h = reference_scenes.SCENES[name].size
        frame = 13.0 if name == "demo" else None
        row = f"{name:<24}"
        for _, options in configs:
            rgba, ms = timed(stage, RenderSettings(width=w, height=h, preset="medium", **options),
                             frame)
            row += f"{mean_flip(rgba, ref):>12.4f} {ms:>7.0f}ms"
        print(row, flush=True)


if __name__ == "__main__":
    main()
