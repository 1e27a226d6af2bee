"""The shots that need bounces, emitters, area-light highlights and glass
(tests/shot_scenes.py) against their committed Cycles references
(tests/references/shots/): per shot and mode, Lantern at medium and high (mean HDR-FLIP,
PSNR and warm time, as `lantern compare` measures them: compare/lantern_timing.py) beside
Cycles at 1, 4, 16 and 64 spp rendered in the same run on the same cores (configured
and timed as compare does: compare/blender_render.py, after one untimed 1-spp render).
Lantern renders each mode as the stage asks it: `direct` saves the shot with Cycles' Max
Bounces 0 (lantern:maxBounces), which Lantern reads (glass then lets no light through).
Prints a Markdown table; asserts nothing.

    nice -n 19 .venv/bin/python bench/bench_shots.py [SHOT[:MODE] ...]
"""
import pathlib
import platform
import sys
import tempfile
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))
sys.path.insert(0, str(TESTS / "references"))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402

from lantern.compare.blender_render import configure_cycles, prepare_output, render  # noqa: E402
from lantern.compare.lantern_timing import time_lantern  # noqa: E402
from lantern.compare.metrics import score  # noqa: E402
from lantern.engine import read_exr  # noqa: E402

import shot_scenes  # noqa: E402
from make_shot_references import FILTER_WIDTH, chosen  # noqa: E402

PRESETS = ("medium", "high")
CYCLES_SAMPLES = (1, 4, 16, 64)
WARM_RUNS = 3


def cell(image, reference, seconds):
    scores = score(image, reference)["all"]
    if scores is None:
        return "non-finite pixels"
    return f"{scores['hdr_flip']:.3f} · {scores['psnr']:.1f} dB ({seconds:.2f} s)"


def lantern_cells(name, mode, workdir):
    """{preset: (rgba, warm seconds, warnings)} of the shot saved as a .blend (in
    `direct` mode with Max Bounces 0, as compare sets Cycles) and rendered as
    `lantern compare` renders it."""
    scene = shot_scenes.build(name)
    if mode == "direct":
        scene.cycles.max_bounces = 0
    blend = str(workdir / f"{name}_{mode}.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    out = {}
    for preset in PRESETS:
        timed = time_lantern(blend, None, shot_scenes.SIZE, preset, False, time.time(), WARM_RUNS)
        out[preset] = (timed["rgba"], timed["warm_seconds"], timed["warnings"])
    return out


def cycles_images(name, mode, workdir):
    """[(spp, rgba, seconds)] of Cycles in `mode` at CYCLES_SAMPLES."""
    scene = shot_scenes.build(name)
    prepare_output(scene)               # float EXR of the raw render, as compare writes it
    configure_cycles(scene, 1, 0, mode, False, FILTER_WIDTH)
    render(scene)                       # untimed: kernel loading
    images = []
    for samples in CYCLES_SAMPLES:
        configure_cycles(scene, samples, 0, mode, False, FILTER_WIDTH)
        path = str(workdir / f"{name}_{mode}_{samples}.exr")
        seconds = render(scene, path)
        images.append((samples, read_exr(path), seconds))
    return images


def main():
    cases = chosen(sys.argv[1:])
    missing = [str(shot_scenes.reference_path(*c)) for c in cases
               if not shot_scenes.reference_path(*c).exists()]
    if missing:
        raise SystemExit("no Cycles reference (make_shot_references.py renders them): "
                         + ", ".join(missing))
    print(f"Shots at {shot_scenes.SIZE[0]}x{shot_scenes.SIZE[1]} against the committed Cycles "
          f"references; {time.strftime('%Y-%m-%d %H:%M')}, {platform.machine()}, "
          f"Blender {bpy.app.version_string}; Lantern warm, median of {WARM_RUNS}.")
    print("Cells: mean HDR-FLIP · PSNR (time).")
    print()
    print("| shot | mode | Lantern medium | Lantern high | "
          + " | ".join(f"Cycles {s} spp" for s in CYCLES_SAMPLES) + " |")
    print("|---|---|---|---|" + "---|" * len(CYCLES_SAMPLES))
    warnings = {}
    with tempfile.TemporaryDirectory(prefix="lantern-shots-") as tmp:
        workdir = pathlib.Path(tmp)
        lantern = {}
        for name, mode in cases:
            if (name, mode) not in lantern:
                lantern[name, mode] = lantern_cells(name, mode, workdir)
            reference = read_exr(str(shot_scenes.reference_path(name, mode)))
            row = [cell(rgba, reference, seconds) for rgba, seconds, _ in
                   (lantern[name, mode][p] for p in PRESETS)]
            row += [cell(rgba, reference, seconds)
                    for _, rgba, seconds in cycles_images(name, mode, workdir)]
            print(f"| {name} | {mode} | " + " | ".join(row) + " |", flush=True)
            warnings[name] = sorted({w for p in PRESETS for w in lantern[name, mode][p][2]})
    print()
    for name, found in warnings.items():
        print(f"{name}: Lantern's warnings: {'; '.join(found) or 'none'}")


if __name__ == "__main__":
    main()
