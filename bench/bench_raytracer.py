"""The ray tracer (engine/gpu/raytracer.py, shaders/raytrace.glsl): building its trees,
refitting them when rigs move, and tracing, on the demo scene (frame 13) and on two
crowds: the tests' (tests/skel_scenes.py: two skinned meshes and a floor) and
bench_session's (16 skinned characters of ~1,200 vertices and a floor).

Per scene: triangles; the first trace's build of every tree (bottom and top, numpy,
uploads included); a frame change's refit of the skinned meshes' trees (their
deformed vertices read back from the GPU included) and the top tree built again;
and 100,000 random rays (origins in the scene's box, directions uniform) traced
closest-hit and any-hit: the dispatch alone, as rays a second (the best of 3).

    python bench/bench_raytracer.py

Prints figures; asserts nothing."""
import os
import pathlib
import sys
import time

import lantern.exporters  # noqa: F401  (Blender's pxr first)
import bpy
import numpy as np

from lantern.engine import RenderSettings, Session
from lantern.exporters import stage_from_depsgraph

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
sys.path.insert(0, str(HERE))
import reference_scenes  # noqa: E402
import skel_scenes  # noqa: E402
from bench_session import crowd_scene  # noqa: E402

RAYS = 100_000
SETTINGS = RenderSettings(width=16, height=16, preset="low")


def demo_stage():
    reference_scenes.build("demo", os.path.join(os.environ.get("TMPDIR", "/tmp"), "lantern-bench-rt"))
    return stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())[0]


def bench(name, stage, frames, box):
    rng = np.random.default_rng(0)
    d = rng.normal(size=(RAYS, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = rng.uniform(box[0], box[1], (RAYS, 3))
    with Session(stage, SETTINGS) as session:
        _, _, first = session.trace(o[:1], d[:1], frame=frames[0])
        trace = {}
        for mode in ("closest", "any"):
            best = np.inf
            for _ in range(3):
                hits, _, counts = session.trace(o, d, frame=frames[0], any_hit=mode == "any")
                best = min(best, counts["seconds"]["trace"])
            trace[mode] = (best, np.count_nonzero(hits.t >= 0))
        refit = []
        for f in frames[1:]:
            before = dict(counts["seconds"])
            _, _, counts = session.trace(o[:1], d[:1], frame=f)
            refit.append({k: counts["seconds"].get(k, 0.0) - before.get(k, 0.0)
                          for k in ("refits", "top_builds")})
    s = first["seconds"]
    print(f"{name}: {first['triangles']:,} triangles, {first['bottom_builds']} bottom trees")
    print(f"  build       {1e3 * (s['bottom_builds'] + s['top_builds']):8.1f} ms "
          f"(bottom {1e3 * s['bottom_builds']:.1f}, top {1e3 * s['top_builds']:.1f})")
    if refit and counts.get("refits"):
        r = min(refit, key=lambda x: x["refits"])
        print(f"  refit       {1e3 * (r['refits'] + r['top_builds']):8.1f} ms "
              f"(skinned trees {1e3 * r['refits']:.1f}, top {1e3 * r['top_builds']:.1f}) "
              f"a frame change, best of {len(refit)}")
    for mode, (seconds, n_hit) in trace.items():
        print(f"  {mode:8s}    {1e3 * seconds:8.1f} ms for {RAYS:,} rays: "
              f"{RAYS / seconds / 1e6:5.2f} M rays/s ({n_hit:,} hit)")


def main():
    print(f"{time.strftime('%Y-%m-%d')}, {os.cpu_count()} cores")
    bench("demo, frame 13", demo_stage(), [13.0, 14.0, 15.0, 16.0], ((-6, -6, -1), (6, 6, 4)))
    bench("tests' crowd", skel_scenes.crowd_stage(), [1.0, 2.0, 3.0, 2.0],
          ((-6, -6, -2), (10, 6, 3)))
    crowd_scene()
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    bench("16-character crowd", stage, [1.0, 2.0, 3.0, 4.0], ((-2, -4, -0.5), (32, 4, 4)))


if __name__ == "__main__":
    main()
