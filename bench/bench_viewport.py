"""The viewport through the engine host: what an edit, a view move or a frame change
costs from Blender's side to the pixels, against the old in-process path (export the
whole scene on any change, a new Session per redraw, pixels handed over with
.tolist()), measured in the same run. Prints figures, asserts nothing.

  1. edit-to-pixels: moving one object among 10, 100 and 1,000 cubes, to the first
     (interactive) and the final frame (goal: independent of the scene's size);
  2. a view orbit on 04_lights.blend at 1280x720: per view while it moves (interactive
     preset) and once it settles (the scene's preset);
  3. a frame change on bench_session's 16-character crowd;
  4. the bytes each edit sends;
  5. the handoff per frame at 1080p: shared memory to a gpu.types.Buffer-sized copy
     and to a render result's foreach_set, against .tolist() (goal <= 5 ms).

    .venv/bin/python bench/bench_viewport.py [--quick]
"""
import argparse
import math
import pathlib
import sys
import time

import lantern.exporters  # noqa: F401  (Blender's pxr first)
import bpy
import numpy as np

from lantern.addon import host as host_module
from lantern.addon.viewport import ViewportRender, view_request
from lantern.core.transforms import look_at
from lantern.engine import RenderSettings, render_stage
from lantern.engine.host import protocol
from lantern.exporters import stage_from_depsgraph

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_session import crowd_scene  # noqa: E402

CORPUS = HERE.parent.parent / "shared" / "corpus" / "blender"
EDIT_SIZE = (640, 360)
ORBIT_SIZE = (1280, 720)
HANDOFF_SIZE = (1920, 1080)
TIMEOUT = 120.0


def ms(seconds):
    return f"{1000.0 * seconds:7.1f} ms"


class Viewport:
    """A viewport synced from Blender's handlers (as view_update would be), with
    the time each frame arrived."""

    def __init__(self):
        self.render = ViewportRender()
        self.handlers = (bpy.app.handlers.depsgraph_update_post,
                         bpy.app.handlers.frame_change_post)
        for handlers in self.handlers:
            handlers.append(self.on_update)
        self.render.update(bpy.context.evaluated_depsgraph_get())

    def on_update(self, scene, depsgraph):
        self.render.update(depsgraph)

    def sent(self):
        return self.render.host.messages

    def edits_since(self, mark):
        return [size for kind, scene, size in self.render.host.sent_since(mark)
                if scene == self.render.name and kind == "edit"]

    def frames(self, view, preset, t0, since):
        """(seconds to the first frame newer than `since`, to the final one); the
        first frame itself is self.first."""
        host, first = self.render.host, None
        depsgraph = bpy.context.evaluated_depsgraph_get()
        while time.perf_counter() - t0 < TIMEOUT:
            self.render.draw(depsgraph, view, lambda *a: None, preset)
            latest = host.channel(self.render.name).latest
            if latest is not None and latest.number > since:
                if first is None:
                    first, self.first = time.perf_counter() - t0, latest
                if latest.final and not self.render.waiting():
                    return first, time.perf_counter() - t0
            time.sleep(0.001)
        raise TimeoutError("no frame")

    def number(self):
        latest = self.render.host.channel(self.render.name).latest
        return latest.number if latest else 0

    def close(self):
        for handlers in self.handlers:
            handlers.remove(self.on_update)
        self.render.close()


def camera_view(scene, size):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = scene.camera.evaluated_get(depsgraph)
    return view_request(size, np.array(camera.matrix_world.inverted()),
                        np.array(camera.calc_matrix_camera(depsgraph, x=size[0], y=size[1])))


def old_path(scene, view):
    """The add-on before the host: the whole scene exported again, a new Session,
    the pixels as a Python list (seconds)."""
    t0 = time.perf_counter()
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    rgba = render_stage(stage, RenderSettings(
        width=view.size[0], height=view.size[1], preset=scene.lantern.preset,
        view_matrix=view.view, projection_matrix=view.projection)).rgba
    rgba[::-1].ravel().tolist()
    return time.perf_counter() - t0


def cubes_scene(n):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    side = math.ceil(math.sqrt(n))
    mesh = bpy.data.meshes.new("cube")
    bpy.ops.mesh.primitive_cube_add(size=0.6)
    template = bpy.context.object
    for i in range(n):
        ob = template if i == 0 else bpy.data.objects.new(f"Cube.{i:04d}", template.data.copy())
        if i:
            scene.collection.objects.link(ob)
        ob.location = ((i % side - side / 2) * 1.2, (i // side - side / 2) * 1.2, 0.3)
    bpy.data.meshes.remove(mesh)
    bpy.ops.mesh.primitive_plane_add(size=side * 1.5)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.rotation_euler = 3.0, (0.6, 0.2, 0.4)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -side * 1.6, side * 1.1)
    camera.rotation_euler = (math.radians(58), 0.0, 0.0)
    for ob in (sun, camera):
        scene.collection.objects.link(ob)
    scene.camera = camera
    scene.lantern.preset = "medium"
    return scene


def edit_latency(counts, runs):
    print(f"1. edit-to-pixels, moving one object among n cubes, {EDIT_SIZE[0]}x{EDIT_SIZE[1]}, "
          "sun with shadows, medium (median of runs). 'edit' is the time outside the "
          "rendering itself (Blender's partial export, the message, the host's stage edit "
          "and Session sync, the handoff); the frames include the render, whose cost "
          "follows what is drawn:")
    print("       n     edit   export   first frame (low, half size)   final frame   "
          "old path (re-export, new Session, tolist)   bytes sent")
    for n in counts:
        scene = cubes_scene(n)
        view = camera_view(scene, EDIT_SIZE)
        viewport = Viewport()
        viewport.frames(view, "medium", time.perf_counter(), 0)
        firsts, finals, sizes, overheads, exports = [], [], [], [], []
        mover = bpy.data.objects["Cube"]
        for run in range(runs):
            since, mark = viewport.number(), viewport.sent()
            t0 = time.perf_counter()
            mover.location.z = 0.3 + 0.5 * (run % 2 + 1)
            bpy.context.view_layer.update()
            exports.append(viewport.render.live.seconds)
            first, final = viewport.frames(view, "medium", t0, since)
            firsts.append(first)
            finals.append(final)
            render = viewport.first.timings["total"] - viewport.first.timings.get("load", 0.0)
            overheads.append(first - render)
            sizes += viewport.edits_since(mark)
        old = [old_path(scene, view) for _ in range(max(1, runs // 3))]
        print(f"   {n:5d}  {ms(np.median(overheads))} {ms(np.median(exports))}   "
              f"{ms(np.median(firsts))}                 {ms(np.median(finals))}     "
              f"{ms(np.median(old))}                                 {int(np.median(sizes))}")
        viewport.close()


def orbit(runs):
    bpy.ops.wm.open_mainfile(filepath=str(CORPUS / "04_lights.blend"), load_ui=False)
    scene = bpy.context.scene
    scene.lantern.preset = "medium"
    base = camera_view(scene, ORBIT_SIZE)
    viewport = Viewport()
    viewport.frames(base, "medium", time.perf_counter(), 0)
    eye = np.linalg.inv(base.view)[:3, 3]
    target = eye + np.linalg.inv(base.view)[:3, :3] @ np.array([0.0, 0.0, -5.0])
    radius = np.linalg.norm((eye - target)[:2])
    moving, mark = [], viewport.sent()
    host = viewport.render.host
    for k in range(runs):
        angle = math.atan2(*(eye - target)[1::-1]) + 0.08 * (k + 1)
        at = target + np.array([radius * math.cos(angle), radius * math.sin(angle), eye[2] - target[2]])
        view = view_request(ORBIT_SIZE, np.linalg.inv(look_at(at, target, np.array([0, 0, 1.0]))),
                            base.projection)
        since = viewport.number()
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < TIMEOUT:              # the moving view's frame
            viewport.render.draw(bpy.context.evaluated_depsgraph_get(), view, lambda *a: None,
                                 "medium")
            latest = host.channel(viewport.render.name).latest
            if latest is not None and latest.number > since:
                moving.append((time.perf_counter() - t0, latest.preset, latest.stats,
                               (latest.width, latest.height)))
                break
            time.sleep(0.001)
    t0 = time.perf_counter()
    _, settled = viewport.frames(view, "medium", t0, viewport.number())
    final = host.channel(viewport.render.name).latest
    edits = viewport.edits_since(mark)
    old = old_path(scene, view)
    presets = {p for _, p, _, _ in moving}
    stats = moving[-1][2]
    sizes = sorted({f"{w}x{h}" for _, _, _, (w, h) in moving})
    print(f"2. view orbit, 04_lights.blend, {ORBIT_SIZE[0]}x{ORBIT_SIZE[1]}, {runs} views:")
    print(f"   per view while moving ({'/'.join(sorted(presets))} preset): "
          f"{ms(np.median([t for t, _, _, _ in moving]))} (median), drawn at "
          f"{', '.join(sizes)} (chosen from the measured frame time), "
          f"{stats['prims_read']} prims read, {stats['bytes_uploaded']} bytes up, "
          f"{stats['shadow_maps_rendered']} shadow maps redrawn")
    print(f"   once still (medium, after {protocol.SETTLE_SECONDS * 1000:.0f} ms settle): "
          f"{ms(settled)} to the final frame, {final.stats['prims_read']} prims read, "
          f"{final.stats['bytes_by_kind'].get('mesh', 0)} mesh bytes up")
    print(f"   old path per view (re-read stage, all uploads and shadows, tolist): {ms(old)}")
    print(f"   edits sent while orbiting: {len(edits)}")
    viewport.close()


def crowd_frames(runs):
    scene = crowd_scene()
    scene.lantern.preset = "medium"
    view = camera_view(scene, EDIT_SIZE)
    viewport = Viewport()
    viewport.frames(view, "medium", time.perf_counter(), 0)
    firsts, finals, sizes, syncs = [], [], [], []
    for k in range(runs):
        since, mark = viewport.number(), viewport.sent()
        t0 = time.perf_counter()
        scene.frame_set(2 + k)
        syncs.append(viewport.render.live.seconds)
        first, final = viewport.frames(view, "medium", t0, since)
        firsts.append(first)
        finals.append(final)
        sizes += viewport.edits_since(mark)
    exports = dict(viewport.render.live.exports)
    t0 = time.perf_counter()
    stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    old_export = time.perf_counter() - t0
    old = old_path(scene, view)
    print(f"3. frame change, 16-character crowd, 3 shadowed lights, {EDIT_SIZE[0]}x{EDIT_SIZE[1]}:")
    print(f"   pose export {ms(np.median(syncs))}, first frame {ms(np.median(firsts))}, final "
          f"{ms(np.median(finals))}; {int(np.median(sizes))} bytes sent per frame change")
    print(f"   old path: {ms(old)} (of which the export sampling the whole "
          f"{scene.frame_end - scene.frame_start + 1}-frame range {ms(old_export)})")
    print(f"   partial exports so far: {exports}")
    viewport.close()


def bytes_per_edit():
    scene = cubes_scene(100)
    view = camera_view(scene, EDIT_SIZE)
    viewport = Viewport()
    viewport.frames(view, "medium", time.perf_counter(), 0)
    cube = bpy.data.objects["Cube"]
    material = bpy.data.materials.new("paint")
    cube.data.materials.append(material)
    bpy.context.view_layer.update()
    bsdf = material.node_tree.nodes["Principled BSDF"]

    def lift():
        cube.data.vertices[0].co.z += 0.1
        cube.data.update()

    edits = [("move one object", lambda: setattr(cube, "location", (0.0, 0.0, 1.0))),
             ("rotate it", lambda: setattr(cube, "rotation_euler", (0.0, 0.0, 0.5))),
             ("edit its mesh (8 vertices)", lift),
             ("its material's base colour", lambda: setattr(bsdf.inputs["Base Color"],
                                                            "default_value", (0, 0, 1, 1))),
             ("the sun's strength", lambda: setattr(bpy.data.lights["Sun"], "energy", 4.0)),
             ("add an object (scene re-exported, difference sent)",
              lambda: bpy.ops.mesh.primitive_uv_sphere_add(location=(0, 0, 3)))]
    print("4. bytes sent per edit (100-cube scene; message = pickled stage fragment):")
    for name, action in edits:
        mark = viewport.sent()
        action()
        bpy.context.view_layer.update()
        sizes = viewport.edits_since(mark)
        print(f"   {name:52s} {sum(sizes):8d} bytes in {len(sizes)} message(s); "
              f"exports: {viewport.render.live.last}")
    viewport.close()
    print("   rig frame change: see 3.")


def handoff(runs):
    w, h = HANDOFF_SIZE
    _, size = protocol.layout(w, h, [])
    block = protocol.create_block(f"lantern_bench_{id(size)}", size)
    try:
        pixels = protocol.view(block, w, h, 4, 0)
        pixels[:] = np.random.default_rng(0).random((h, w, 4), np.float32)
        target = np.empty(w * h * 4, np.float32)
        image = bpy.data.images.new("handoff", w, h, float_buffer=True)
        copy, foreach, tolist = [], [], []
        for _ in range(runs):
            t0 = time.perf_counter()
            np.copyto(target, pixels.reshape(-1))        # what gpu.types.Buffer does with it
            copy.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            image.pixels.foreach_set(pixels.reshape(-1))  # what F12 does, into a result
            foreach.append(time.perf_counter() - t0)
        for _ in range(max(1, runs // 5)):
            t0 = time.perf_counter()
            pixels.reshape(-1).tolist()
            tolist.append(time.perf_counter() - t0)
        del pixels
    finally:
        protocol.release_block(block, unlink=True)
    print(f"5. handoff per frame at {w}x{h} (RGBA float32, {size / 2**20:.1f} MiB), median:")
    print(f"   shared memory -> one copy (a gpu.types.Buffer's) {ms(np.median(copy))}; "
          f"-> foreach_set {ms(np.median(foreach))}; old .tolist() alone "
          f"{ms(np.median(tolist))} (goal <= 5 ms)")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true", help="fewer runs, smaller scenes")
    args = parser.parse_args()
    runs = 3 if args.quick else 7
    import lantern
    lantern.register()                         # the add-on's properties and engine
    host = host_module.get()
    try:
        handoff(runs * 3)
        edit_latency((10, 100) if args.quick else (10, 100, 1000), runs)
        bytes_per_edit()
        orbit(runs)
        crowd_frames(runs)
        if host.info:
            print(f"engine host: {host.info['gl']}")
    finally:
        lantern.unregister()                   # stops the host


if __name__ == "__main__":
    main()
