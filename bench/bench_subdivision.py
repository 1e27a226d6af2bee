"""Subdivision surfaces exported as cages against CPU-applied levels 1-3: export size
and time, points written, and the engine's CPU refinement time against its points;
then each exported file rendered (640x360, medium): the cage tessellated by the GPU
(GL 4.3), the cage refined on the CPU (GL 3.3's path), and the applied levels, with
the bytes uploaded, triangles drawn, a still frame's time, a frame after a view change
(the tessellation cut again), and the HDR-FLIP and PSNR against applied level 3.

Runs in Blender's Python (bpy): `.venv/bin/python bench/bench_subdivision.py`.
Scenes: Suzanne at render level 2, and 100 subdivided Suzannes (level 2).
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


def look_at(eye, target):
    """OpenGL world-to-view matrix, Z up."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, (0, 0, 1.0))
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = r, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


PROJECTION = np.array([[1.0, 0, 0, 0], [0, 16 / 9, 0, 0], [0, 0, -1.0002, -0.020002],
                       [0, 0, -1, 0]])


def render_figures(path, px, views):
    """(bytes uploaded by the first render, triangles drawn, still-frame ms, view-change
    ms, the image) of one file."""
    from pxr import Usd

    from lantern.engine import RenderSettings, Session

    with Session(Usd.Stage.Open(path), RenderSettings(width=640, height=360, preset="medium",
                                                      tessellation_px=px)) as s:
        first = s.render(view_matrix=views[0], projection_matrix=PROJECTION)
        uploaded = first.stats["bytes_uploaded"]
        triangles = sum(count for d in s._renderer.geometry.draws.values()
                        for _, _, count in d.ranges) // 3
        still, moved = [], []
        for i in range(5):
            s.render(view_matrix=views[0], projection_matrix=PROJECTION)
            t = time.perf_counter()
            s.render(view_matrix=views[0], projection_matrix=PROJECTION)   # the same view
            still.append(time.perf_counter() - t)
            t = time.perf_counter()
            s.render(view_matrix=views[1 + i % 2], projection_matrix=PROJECTION)
            moved.append(time.perf_counter() - t)
        image = s.render(view_matrix=views[0], projection_matrix=PROJECTION).rgba
    return uploaded, triangles, np.median(still) * 1e3, np.median(moved) * 1e3, image


def renders(tmp, count):
    from lantern.compare.metrics import score

    target = (0, 0, 0) if count == 1 else (13.5, 13.5, 0)
    eye = (0, -4.5, 1.2) if count == 1 else (13.5, -22, 14)
    views = [look_at(eye, target), look_at(np.add(eye, (0.05, 0, 0)), target),
             look_at(np.add(eye, (-0.05, 0, 0)), target)]
    rows = [("cage, GPU tessellation", "cage.usdc", 4.0), ("cage, CPU level 2", "cage.usdc", 0.0)]
    rows += [(f"applied L{level}", f"l{level}.usdc", 0.0) for level in (1, 2, 3)]
    figures = {name: render_figures(os.path.join(tmp, f), px, views) for name, f, px in rows}
    reference = figures["applied L3"][4]
    print(f"\n{count} Suzanne(s) rendered, 640x360 medium (reference: applied L3)")
    print(f"{'':>24} {'uploaded':>10} {'triangles':>10} {'still ms':>9} {'view ms':>8} "
          f"{'HDR-FLIP':>9} {'PSNR':>6}")
    for name, (uploaded, triangles, still, moved, image) in figures.items():
        s = score(image, reference)["all"] if image is not reference else None
        error = f"{s['hdr_flip']:9.4f} {s['psnr']:6.1f}" if s else f"{'reference':>16}"
        print(f"{name:>24} {uploaded:10d} {triangles:10d} {still:9.1f} {moved:8.1f} {error}")


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
        renders(tmp, count)
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
