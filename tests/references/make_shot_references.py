"""Renders the shots that need bounces, emitters, area-light highlights and glass
(tests/shot_scenes.py) with Cycles once; the small EXRs are committed as
shots/<shot>_<mode>.exr (RGB, half float, ZIP).

Cycles as `lantern compare` configures it (compare/blender_render.configure_cycles):
CPU, seed 0, no denoiser, no adaptive sampling, clamps off, light threshold 0,
Blackman-Harris 1.5 px; `full` mode keeps a new scene's bounces (max 12, diffuse 4,
glossy 4, transmission 12), `direct` sets max bounces 0. Each shot in the modes
shot_scenes.SHOTS lists, at shot_scenes.SIZE (160 x 120).

Samples: SAMPLES (1,024) per pixel. On this machine (2 cores shared with other work, load
6 to 9) the eight cases took 18 minutes at nice 19 on 2026-11-28: the closed box in
full mode 338 s, in direct mode 89 s; the sunlit room 144 s; the emissive table 178 s
and 145 s; the glass sphere 67 s and 44 s; the glossy floor 54 s. `--samples N` renders
at N (then say so in docs/compare.md).

Run from the repository root, niced (the cores are shared):
    nice -n 19 .venv/bin/python tests/references/make_shot_references.py [--samples N] [SHOT[:MODE] ...]
"""
import pathlib
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from make_cycles_references import write_exr  # noqa: E402  (Blender's pxr first)

from lantern.compare.blender_render import configure_cycles  # noqa: E402

import shot_scenes  # noqa: E402

SAMPLES = 1024
FILTER_WIDTH = 1.5   # Cycles' default pixel filter, as compare uses


def render(name, mode, samples):
    scene = shot_scenes.build(name)
    bounces = configure_cycles(scene, samples, seed=0, mode=mode, denoise=False,
                               filter_width=FILTER_WIDTH)
    path = shot_scenes.reference_path(name, mode)
    path.parent.mkdir(exist_ok=True)
    start = time.perf_counter()
    write_exr(scene, path, half=True, rgb=True)
    print(f"{name} {mode}: {samples} spp, bounces {bounces}, "
          f"{time.perf_counter() - start:.1f} s", flush=True)


def chosen(args):
    """(shot, mode) pairs named as SHOT or SHOT:MODE; every case when none is named."""
    if not args:
        return shot_scenes.cases()
    pairs = []
    for arg in args:
        name, _, mode = arg.partition(":")
        modes = [mode] if mode else list(shot_scenes.SHOTS[name].modes)
        pairs += [(name, m) for m in modes]
    return pairs


if __name__ == "__main__":
    argv = sys.argv[1:]
    samples = SAMPLES
    if argv[:1] == ["--samples"]:
        samples, argv = int(argv[1]), argv[2:]
    for shot, shot_mode in chosen(argv):
        render(shot, shot_mode, samples)
