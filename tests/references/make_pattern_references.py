"""Renders the node-network scenes (tests/pattern_scenes.py) with Cycles once; the
small EXRs are committed as patterns/<scene>.exr (RGB, half float, ZIP).

Cycles as for references/looks/ (make_cycles_references.configure_cycles: CPU, seed 0,
no denoiser, direct light only, Blackman-Harris 1.5 px), pattern_scenes.SAMPLES spp
(SAMPLES_OF where a scene needs more) at pattern_scenes.SIZE. Run from the repository root:
    .venv/bin/python tests/references/make_pattern_references.py [NAME ...]
"""
import pathlib
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from make_cycles_references import configure_cycles, write_exr  # noqa: E402

import pattern_scenes  # noqa: E402

OUT = HERE / "patterns"


def render(name):
    scene = pattern_scenes.SCENES[name]()
    configure_cycles(scene, pattern_scenes.SAMPLES_OF.get(name, pattern_scenes.SAMPLES),
                     point_filter=False)
    OUT.mkdir(exist_ok=True)
    start = time.perf_counter()
    write_exr(scene, OUT / f"{name}.exr", half=True, rgb=True)
    print(f"{name}: {time.perf_counter() - start:.1f} s", flush=True)


if __name__ == "__main__":
    for scene_name in sys.argv[1:] or pattern_scenes.SCENES:
        render(scene_name)
