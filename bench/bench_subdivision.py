"""Subdivision surfaces exported as cages against CPU-applied levels 1-3: export size
and time, points written, and the engine's CPU refinement time against its points.

Runs in Blender's Python (bpy): `.venv/bin/python bench/bench_subdivision.py`.
Scenes: Suzanne at render level 2, and 100 subdivided Suzannes (level 2).
Frame time and image difference are not measured here yet.
"""
import os
import sys
import tempfile
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from lantern.engine.subdivision import cage, refine  # noqa: E402
from lantern.exporters.api import ExportOptions, export_depsgraph_to_file  # noqa: E402


def scene(count):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for i in range(count):
        bpy.ops.mesh.primitive_monkey_add(location=(3 * (i % 10), 3 * (i // 10), 0))
        ob = bpy.context.active_object
        ob.data = ob.data.copy()  # not shared: each is its own mesh, as in a real scene
        # Each its own shape too: USD's crate format stores identical arrays once.
        co = np.empty(len(ob.data.vertices) * 3, np.float32)
        ob.data.vertices.foreach_get("co", co)
        co += np.random.default_rng(i).normal(0, 1e-3, co.shape).astype(np.float32)
        ob.data.vertices.foreach_set("co", co)
        mod = ob.modifiers.new("subsurf", "SUBSURF")
        mod.levels = mod.render_levels = 2
    bpy.context.view_layer.update()


def export(mode, level, out):
    for ob in bpy.context.scene.objects:
        ob.modifiers["subsurf"].levels = ob.modifiers["subsurf"].render_levels = level
    bpy.context.view_layer.update()
    start = time.perf_counter()
    report = export_depsgraph_to_file(bpy.context.evaluated_depsgraph_get(), out,
                                      ExportOptions(subdivision=mode, animation=False))
    return time.perf_counter() - start, os.path.getsize(out), report


def points_of(ob, apply):
    deps = bpy.context.evaluated_depsgraph_get()
    me = ob.evaluated_get(deps).to_mesh() if apply else ob.data
    n = len(me.vertices)
    if apply:
        ob.evaluated_get(deps).to_mesh_clear()
    return n


def main():
    tmp = tempfile.mkdtemp()
    for count in (1, 100):
        scene(count)
        print(f"\n{count} Suzanne(s), Catmull-Clark")
        print(f"{'export':>14} {'seconds':>8} {'bytes':>10} {'points/object':>14}")
        t, size, report = export("cage", 2, os.path.join(tmp, "cage.usdc"))
        print(f"  meshes written: {report.counts['meshes']}")
        print(f"{'cage (level 2)':>14} {t:8.3f} {size:10d} {points_of(bpy.context.scene.objects[0], False):14d}")
        for level in (1, 2, 3):
            t, size, _ = export("apply", level, os.path.join(tmp, f"l{level}.usdc"))
            n = points_of(bpy.context.scene.objects[0], True)
            print(f"{'applied L' + str(level):>14} {t:8.3f} {size:10d} {n:14d}")
    me = bpy.context.scene.objects[0].data
    c = cage(np.array([v.co for v in me.vertices], np.float64),
             [p.loop_total for p in me.polygons], [l.vertex_index for l in me.loops])
    print("\nengine CPU refinement of one Suzanne cage (numpy)")
    for level in (1, 2, 3):
        start = time.perf_counter()
        out = refine(c, level)
        t = time.perf_counter() - start
        print(f"  level {level}: {t * 1000:8.1f} ms, {len(out.points)} points, "
              f"{len(out.points) * 12} position bytes")


if __name__ == "__main__":
    main()
