"""engine.Session: what a render costs when only the view, one object or the time
changes. Prints figures (medians of several renders), asserts nothing.

  1. cold against warm: the first render of a stage (reading, uploads; and in a new
     process, compiling programs) against later renders of the same view;
  2. a view change on 1,000 separate cubes against the same cubes merged into one mesh
     (same materials, by face subsets), at 320x180, with the default light rig and
     with two shadow-casting lights: the cost of many objects (goal <= 1.2x);
  3. a one-object edit through the USD API on the 1,000 cubes;
  4. a frame change on a 16-character skinned crowd at 640x360 under three shadowed
     lights (sun, point, spot), with the bytes it uploads, against EEVEE at 1 sample
     rendering the same Blender scene and frame change in the same run.

    .venv/bin/python bench/bench_session.py
"""
import os
import pathlib
import sys
import time

import lantern.exporters  # noqa: F401  (Blender's pxr first)
import bpy
import numpy as np
from pxr import Gf, UsdGeom

from lantern.engine import RenderSettings, Session
from lantern.exporters import stage_from_depsgraph

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
sys.path.insert(0, str(HERE))
import session_scenes as scenes  # noqa: E402
from bench_skel_export import _character  # noqa: E402  (the crowd's characters)

RUNS = 9
SMALL = (320, 180)
CROWD_SIZE = (640, 360)


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def median_ms(values):
    return 1000.0 * float(np.median(values))


def cold_and_warm():
    stage = scenes.cubes_stage(1000, lights=("point", "spot"))
    settings = RenderSettings(width=SMALL[0], height=SMALL[1])
    with Session(stage, settings) as session:
        process_cold, first = timed(session.render)
        warm = [timed(session.render)[0] for _ in range(RUNS)]
    session_cold = []
    for _ in range(3):
        with Session(stage, settings) as session:
            session_cold.append(timed(session.render)[0])
    print(f"1,000 cubes + 2 shadowed lights, {SMALL[0]}x{SMALL[1]}:")
    print(f"  first render, new process (programs compiled): {process_cold * 1000:8.1f} ms "
          f"(reading USD {first.timings['load'] * 1000:.0f} ms, "
          f"{first.stats['bytes_uploaded'] / 1e6:.2f} MB uploaded)")
    print(f"  first render, new session (programs cached):   {median_ms(session_cold):8.1f} ms "
          f"(median of 3 sessions)")
    print(f"  later render, same view (warm):                {median_ms(warm):8.1f} ms")


def many_objects():
    """Both stages in one loop, a view of each in turn, so that the machine's noise
    hits both alike (the ratio is of the medians)."""
    for lights, label in (((), "default light rig"), (("point", "spot"), "2 shadowed lights")):
        stages = [scenes.cubes_stage(1000, merged=m, lights=lights) for m in (False, True)]
        views = scenes.orbit_views(stages[0], 2 * RUNS + 1, SMALL[0] / SMALL[1])
        settings = RenderSettings(width=SMALL[0], height=SMALL[1])
        sessions = [Session(st, settings) for st in stages]
        os.environ["LANTERN_MAX_GL"] = "33"     # the separate cubes again, on the GL 3.3 path
        sessions.append(Session(stages[0], settings))
        del os.environ["LANTERN_MAX_GL"]
        times, last, most = [[], [], []], [None] * 3, [0] * 3
        try:
            for k, view in enumerate(views):
                for i, session in enumerate(sessions):
                    t, result = timed(lambda: session.render(*view))
                    if k:                                  # the first view warms up
                        times[i].append(t)
                        last[i] = result.stats
                        most[i] = max(most[i], result.stats["bytes_uploaded"])
        finally:
            for session in sessions:
                session.close()
        sep, mer, gl33 = (median_ms(t) for t in times)
        print(f"view change, {label}: 1,000 separate cubes {sep:6.1f} ms "
              f"({last[0]['draw_calls']} draws, {last[0]['gl_path']}, <= {most[0]} bytes up), "
              f"merged into one mesh {mer:6.1f} ms ({last[1]['draw_calls']} draws): "
              f"ratio {sep / mer:.2f}x (goal <= 1.2x); "
              f"{last[2]['gl_path']} {gl33:6.1f} ms ({gl33 / mer:.2f}x)")


def one_object_edit():
    stage = scenes.cubes_stage(1000, lights=("point", "spot"))
    with Session(stage, RenderSettings(width=SMALL[0], height=SMALL[1])) as session:
        session.render()
        runs = []
        for i in range(RUNS):
            op = UsdGeom.Xformable(stage.GetPrimAtPath(f"/root/c{100 * i + 7:04d}")) \
                .GetOrderedXformOps()[0]
            op.Set(op.Get() + Gf.Vec3d(0.3, 0.0, 0.4))
            runs.append(timed(session.render))
    last = runs[-1][1].stats
    print(f"one-object edit on the 1,000 cubes (2 shadowed lights): {median_ms([t for t, _ in runs]):6.1f} ms, "
          f"{last['prims_read']} prim read, {last['bytes_uploaded']} bytes up, "
          f"{last['shadow_maps_rendered']} shadow maps touched ({last['shadow_passes']} tiles redrawn: "
          f"those the cube moved in or out of)")


def crowd_scene():
    """bench_skel_export's crowd (16 characters, 12 bones, ~1,200 vertices each) on a
    floor, under a sun, a point and a spot light, all casting shadows, and a camera."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 24
    for i in range(16):
        _character(i)
    bpy.ops.mesh.primitive_plane_add(size=60.0, location=(15.0, 0.0, 0.0))
    for name, kind, energy, loc, rot in (
            ("Sun", "SUN", 3.0, (0, 0, 10), (0.6, 0.2, 0.4)),
            ("Lamp", "POINT", 3000.0, (10.0, -4.0, 6.0), (0, 0, 0)),
            ("Spot", "SPOT", 20000.0, (20.0, -8.0, 10.0), (0.7, 0.0, 0.3))):
        light = bpy.data.lights.new(name, kind)
        light.energy = energy
        light.use_shadow = True
        ob = bpy.data.objects.new(name, light)
        ob.location, ob.rotation_euler = loc, rot
        scene.collection.objects.link(ob)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (15.0, -24.0, 12.0)
    cam.rotation_euler = (np.radians(62), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = CROWD_SIZE
    scene.render.resolution_percentage = 100
    scene.frame_set(1)
    return scene


def eevee_frames(scene, frames):
    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.taa_render_samples = 1
    scene.frame_set(frames[0])
    bpy.ops.render.render()                       # compiles EEVEE's shaders
    times = []
    for f in frames[1:]:
        scene.frame_set(f)
        times.append(timed(bpy.ops.render.render)[0])
    return times


def crowd():
    scene = crowd_scene()
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    frames = list(range(1, RUNS + 2))
    with Session(stage, RenderSettings(width=CROWD_SIZE[0], height=CROWD_SIZE[1])) as session:
        session.render(frame=frames[0])
        runs = [timed(lambda f=f: session.render(frame=float(f))) for f in frames[1:]]
    ours = [t for t, _ in runs]
    s = runs[-1][1].stats
    eevee = eevee_frames(scene, frames)
    kinds = ", ".join(f"{k} {v}" for k, v in sorted(s["bytes_by_kind"].items()))
    print(f"crowd frame change, 16 characters x ~1,200 vertices, 3 shadowed lights, "
          f"{CROWD_SIZE[0]}x{CROWD_SIZE[1]}:")
    print(f"  Lantern {median_ms(ours):7.1f} ms (goal 100 ms): {s['meshes_skinned']} meshes "
          f"skinned once each, {s['shadow_maps_rendered']} shadow maps redrawn "
          f"({s['shadow_passes']} tiles), {s['prims_read']} prims read, "
          f"{s['bytes_uploaded']} bytes up ({kinds})")
    print(f"  EEVEE, 1 sample {median_ms(eevee):7.1f} ms: ratio Lantern / EEVEE "
          f"{np.median(ours) / np.median(eevee):.3f}")
    print("  Lantern passes, GPU (ms): " + ", ".join(
        f"{k} {v * 1000:.1f}" for k, v in runs[-1][1].gpu_timings.items()))


def main():
    print(f"bench_session ({time.strftime('%Y-%m-%d')}, {os.cpu_count()} cores, "
          f"medians of {RUNS} renders)")
    cold_and_warm()                      # first: the process has compiled nothing yet
    many_objects()
    one_object_edit()
    crowd()


if __name__ == "__main__":
    main()
