"""Presets, cost against error on the reference suite (tests/reference_scenes.py): every scene of
tests/reference_scenes.py, built as the Cycles references were, rendered at its
reference size with each preset; mean HDR-FLIP against the committed Cycles reference
and the warm render time (median of 3). Prints one row per scene and the suite's mean
FLIP and summed time per preset; asserts nothing.

    .venv/bin/python bench/bench_presets.py [--candidates] [SCENE ...]

--candidates also measures the alternatives the preset table was tuned against
(CANDIDATES below), so the choice can be checked again."""
import dataclasses
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
from lantern.core import presets as preset_table  # noqa: E402
from lantern.engine import RenderSettings, Session, read_exr  # noqa: E402
from lantern.exporters import stage_from_depsgraph  # noqa: E402

LOOKS = TESTS / "references" / "looks"
FRAMES = {"demo": 13.0}          # the frame the reference shows

# Alternatives measured when the table was tuned: name -> (base preset, changes).
CANDIDATES = {
    "high, ss1": ("high", dict(supersample=1, fxaa=True)),
    "high, medium taps": ("high", dict(pcf_taps=16, blocker_taps=12, ao_slices=3, ao_steps=8)),
    "ultra, ss2": ("ultra", dict(supersample=2)),
    "ultra, high taps": ("ultra", dict(pcf_taps=32, blocker_taps=16, ao_slices=4, ao_steps=12)),
    "ultra, high shadow taps": ("ultra", dict(pcf_taps=32, blocker_taps=16)),
    "low, AO every pixel": ("low", dict(ao_block=1)),
    "medium, AO every pixel": ("medium", dict(ao_block=1)),
    "high, AO in 2x2 blocks": ("high", dict(ao_block=2)),
    "high, no edge samples": ("high", dict(edge_samples=False)),
    "ultra, no edge samples": ("ultra", dict(edge_samples=False)),
}


def measure(stage, name, preset):
    w, h = reference_scenes.SCENES[name].size
    settings = RenderSettings(width=w, height=h, preset=preset)
    with Session(stage, settings) as session:
        session.render(frame=FRAMES.get(name))
        times = []
        for _ in range(3):
            start = time.perf_counter()
            result = session.render(frame=FRAMES.get(name))
            times.append(time.perf_counter() - start)
    return mean_flip(result.rgba, read_exr(str(LOOKS / f"{name}.exr"))), float(np.median(times)) * 1000


def main(args):
    candidates = "--candidates" in args
    names = [a for a in args if not a.startswith("--")] or list(reference_scenes.SCENES)
    presets = list(preset_table.PRESETS)
    if candidates:
        for label, (base, changes) in CANDIDATES.items():
            preset_table.PRESETS[label] = dataclasses.replace(preset_table.PRESETS[base],
                                                              name=label, **changes)
            presets.append(label)
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="lantern-presets-"))
    print(f"presets on the reference suite, {time.strftime('%Y-%m-%d')}: mean HDR-FLIP / warm ms")
    print(f"{'scene':<24}" + "".join(f"{p:>22}" for p in presets))
    totals = {p: [0.0, 0.0] for p in presets}
    for name in names:
        reference_scenes.build(name, workdir)
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        row = f"{name:<24}"
        for p in presets:
            flip, ms = measure(stage, name, p)
            totals[p][0] += flip / len(names)
            totals[p][1] += ms
            row += f"{flip:>13.4f} {ms:>6.0f}ms"
        print(row, flush=True)
    print(f"{'mean FLIP / total ms':<24}" + "".join(f"{f:>13.4f} {ms:>6.0f}ms"
                                                 for f, ms in totals.values()))


if __name__ == "__main__":
    main(sys.argv[1:])
