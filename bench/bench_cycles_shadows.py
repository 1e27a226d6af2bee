"""Presets trade time for error: each light type's box-on-plane scene, rendered at every
preset, against the committed Cycles references (tests/references/cycles_box_*.exr).
Prints render time (median of 3, warm) next to mean HDR-FLIP and PSNR; asserts nothing.
"""
import pathlib
import sys
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import calibration  # noqa: E402
from image_metrics import mean_flip, psnr  # noqa: E402
from lantern.engine import RenderSettings, read_exr, render_stage  # noqa: E402
from lantern.core.presets import PRESETS  # noqa: E402
from lantern.exporters import stage_from_depsgraph  # noqa: E402


def warm_render(stage, settings, repeats=3):
    """The last of `repeats` renders after a first one (programs, uploads), and their
    median time in ms."""
    render_stage(stage, settings)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = render_stage(stage, settings)
        times.append(time.perf_counter() - start)
    return result, float(np.median(times)) * 1000


def main():
    width, height = calibration.BOX_SIZE
    print(f"box on plane at {width}x{height} vs Cycles 2048 spp ({time.strftime('%Y-%m-%d')}, llvmpipe)")
    print(f"{'light':<7}" + "".join(f"{p + ' ms':>12}{'FLIP':>8}{'PSNR':>7}" for p in PRESETS))
    for kind in calibration.BOX_LIGHTS:
        calibration.build_box_scene(kind)
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        cycles = read_exr(str(TESTS / "references" / f"cycles_box_{kind}.exr"))
        row = f"{kind:<7}"
        for preset in PRESETS:
            settings = RenderSettings(width=width, height=height, preset=preset)
            result, ms = warm_render(stage, settings)
            row += (f"{ms:>12.1f}{mean_flip(result.rgba, cycles):>8.4f}"
                    f"{psnr(result.rgba, cycles):>7.1f}")
        print(row)


if __name__ == "__main__":
    main()
