"""Per-material cost of node networks (docs/materials.md): 100 quads, each its own
material, seen from above (tests/pattern_scenes.py's layout), in three versions:

- plain:    100 Principled BSDFs with constant colours (UsdPreviewSurface, the fast path);
- shared:   100 Hue/Saturation/Value networks with other values (one graph shape);
- distinct: the node-family quads of tests/pattern_scenes.py plus Hue/Saturation/Value
            ones, 100 materials of about 80 graph shapes.

For each: the first render of a new Session (cold: makes its programs, compiled or
loaded from the persistent program cache), a new Session on the same stage afterwards
(the process's programs), and the warm
G-buffer GPU time per frame (result.gpu_timings["gbuffer"], median of 7 frames),
640 x 640, medium preset. Prints; asserts nothing.

    .venv/bin/python bench/bench_materials.py
"""
import pathlib
import sys
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402,F401
import numpy as np  # noqa: E402

import pattern_scenes as P  # noqa: E402
from lantern.engine import RenderSettings, Session  # noqa: E402
from lantern.exporters import stage_from_depsgraph  # noqa: E402

SIZE = (640, 640)
COUNT = 100


def _plain(i):
    def build(tree, bsdf):
        bsdf.inputs["Base Color"].default_value = (i / COUNT, 0.5, 1.0 - i / COUNT, 1.0)
    return build


def _hsv(i):
    return P._hsv(i / COUNT - 0.5, 0.5 + i / COUNT, 0.8 + 0.2 * (i % 3))


def scene(kind):
    if kind == "plain":
        builders = [(f"m{i}", _plain(i)) for i in range(COUNT)]
    elif kind == "shared":
        builders = [(f"m{i}", _hsv(i)) for i in range(COUNT)]
    else:
        builders = P.family_builders()
        builders += [(f"hsv{i}", _hsv(i)) for i in range(COUNT - len(builders))]
    P._grid(f"bench_{kind}", builders[:COUNT], columns=10, size=SIZE)
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    return stage


def measure(stage):
    settings = RenderSettings(width=SIZE[0], height=SIZE[1], preset="medium")
    with Session(stage, settings) as session:
        t = time.perf_counter()
        first = session.render()
        cold = time.perf_counter() - t
        gbuffer = []
        for _ in range(7):
            gbuffer.append(session.render().gpu_timings.get("gbuffer", float("nan")))
    with Session(stage, settings) as session:
        t = time.perf_counter()
        again = session.render()
        cached = time.perf_counter() - t
    made = first.stats["programs_compiled"] + first.stats["programs_loaded"]
    return dict(cold_ms=1000 * cold, compiled=made,
                compile_ms=1000 * first.timings["programs"],
                cached_ms=1000 * cached,
                cached_compiled=again.stats["programs_compiled"] + again.stats["programs_loaded"],
                gbuffer_ms=1000 * float(np.median(gbuffer)),
                draws=first.stats["draw_calls"], pattern_bytes=first.stats["pattern_bytes"])


def main():
    # The process's own programs (lights, post, the plain G-buffer variant) first, so
    # that each scene's first render compiles only what its materials need.
    P._grid("warm_up", [("m", _plain(0))], size=(64, 64))
    with Session(stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())[0],
                 RenderSettings(width=64, height=64, preset="medium")) as session:
        session.render()
    rows = {}
    for kind in ("plain", "shared", "distinct"):
        rows[kind] = measure(scene(kind))
        print(kind, rows[kind], flush=True)
    base = rows["plain"]["gbuffer_ms"]
    print("\n| materials | first render ms (programs made, ms making them) | new session ms "
          "(compiled) | G-buffer GPU ms/frame | vs plain | pattern bytes/frame |")
    print("|---|---|---|---|---|---|")
    for kind, r in rows.items():
        print(f"| {kind} | {r['cold_ms']:.0f} ({r['compiled']}, {r['compile_ms']:.0f}) "
              f"| {r['cached_ms']:.0f} "
              f"({r['cached_compiled']}) | {r['gbuffer_ms']:.2f} | {r['gbuffer_ms'] / base:.2f} "
              f"| {r['pattern_bytes']} |")


if __name__ == "__main__":
    main()
