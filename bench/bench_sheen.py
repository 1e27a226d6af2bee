"""What a sheen costs and what it buys (docs/rendering.md, "Sheen"): the sheen scene of
tests/reference_scenes.py (six spheres: the Principled BSDF's sheen, Sheen BSDFs added
and alone), drawn with its sheens and with them left out (lantern:sheenMode removed:
no g_sheen target, no SHEEN variant).

Error: HDR-FLIP against the committed Cycles reference at its size (280 x 48), at the
medium and ultra presets. Cost: the same scene at 5x that size (1400 x 240), medium,
frames of the two stages interleaved in two Sessions; medians of 9 warm frames of the
wall time and of the G-buffer, ambient and light passes' GPU time. Prints; asserts
nothing.

    .venv/bin/python bench/bench_sheen.py
"""
import pathlib
import sys
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import reference_scenes  # noqa: E402
from image_metrics import mean_flip  # noqa: E402
from lantern.engine import RenderSettings, Session, read_exr, render_stage  # noqa: E402
from lantern.exporters import stage_from_depsgraph  # noqa: E402

FRAMES = 9
PASSES = ("gbuffer", "ambient", "lights")


def stages():
    """(with sheen, without): the second a copy with every lantern:sheenMode removed."""
    reference_scenes.build("sheen", pathlib.Path("/tmp") / "lantern-bench-sheen")
    with_sheen, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    without, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    for prim in without.Traverse():
        if prim.GetTypeName() == "Material":
            prim.RemoveProperty("lantern:sheenMode")
    return with_sheen, without


def main():
    pair = stages()
    ref = read_exr(str(TESTS / "references" / "looks" / "sheen.exr")).astype(np.float64)
    w, h = reference_scenes.SCENES["sheen"].size
    for preset in ("medium", "ultra"):
        flips = [mean_flip(render_stage(s, RenderSettings(width=w, height=h, preset=preset)).rgba,
                           ref) for s in pair]
        print(f"HDR-FLIP {preset}: with sheen {flips[0]:.4f}, left out {flips[1]:.4f}")
    settings = RenderSettings(width=5 * w, height=5 * h, preset="medium")
    sessions = [Session(s, settings) for s in pair]
    try:
        for session in sessions:
            session.render()                       # programs, uploads
        wall, gpu = ([[], []], [[], []])
        for _ in range(FRAMES):
            for k, session in enumerate(sessions):
                t = time.perf_counter()
                result = session.render()
                wall[k].append(time.perf_counter() - t)
                gpu[k].append(sum(result.gpu_timings.get(p, 0.0) for p in PASSES))
    finally:
        for session in sessions:
            session.close()
    print(f"\n{5 * w} x {5 * h}, medium, median of {FRAMES} warm frames (ms):")
    print("| | frame wall | G-buffer + ambient + lights GPU |\n|---|---|---|")
    for k, label in enumerate(("with sheen", "sheen left out")):
        print(f"| {label} | {1000 * np.median(wall[k]):.1f} | {1000 * np.median(gpu[k]):.1f} |")


if __name__ == "__main__":
    main()
