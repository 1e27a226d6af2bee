"""A fresh bpy process that plays a real Blender: installs the built extension zip and
uses it. Run by tests/test_addon_install.py, which checks what this writes:

    python tests/_addon_host.py EXTENSION.zip OUT_DIR CORPUS_DIR DEMO.blend

- The process has a home of its own, a temporary folder (HOME; no XDG_* folders and no
  LANTERN_PROGRAM_CACHE_DIR), with Blender's user resources (preferences, extensions,
  the extracted wheels) in it as a real user's are: nothing leaks into the machine,
  and whatever Lantern leaves in the home is seen.
- Every module a real Blender does not bundle is unimportable, in this process and in
  the engine host's child process (tests/blender_only/sitecustomize.py): whatever the
  venv's site-packages holds beyond bpy and the packages bpy itself requires (Blender
  bundles those), plus a list named by the brief. So moderngl and glcontext must come
  from the zip's wheels, pxr from Blender's own USD, and the add-on from the zip, not
  from the editable `lantern` install.
- Renders are tiny (64x36). Images go to OUT_DIR as EXR, everything else to
  OUT_DIR/report.json; a step that fails records its error and the rest go on.
"""
import importlib.util
import json
import os
import shutil
import sys
import tempfile
import threading
import time
import traceback

ZIP, OUT, CORPUS, DEMO = (os.path.abspath(p) for p in sys.argv[1:5])
WIDTH, HEIGHT = 64, 36

# --- module hiding (before anything else is imported), here and in the engine host's
# child process (PYTHONPATH carries the same sitecustomize to it) --------------------
BLENDER_ONLY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_only")
_spec = importlib.util.spec_from_file_location("blender_only",
                                               os.path.join(BLENDER_ONLY, "sitecustomize.py"))
blender_only = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(blender_only)
NOT_IN_BLENDER = blender_only.NOT_IN_BLENDER
os.environ["PYTHONPATH"] = BLENDER_ONLY
HOME = tempfile.mkdtemp(prefix="home-", dir=OUT)  # inside OUT even if this crashes
os.environ["HOME"] = HOME
for _name in ("XDG_CACHE_HOME", "XDG_CONFIG_HOME", "XDG_DATA_HOME", "LANTERN_PROGRAM_CACHE_DIR"):
    os.environ.pop(_name, None)
USER = os.path.join(HOME, ".config", "blender")
os.makedirs(USER)
os.environ["BLENDER_USER_RESOURCES"] = USER

import bpy  # noqa: E402  (after the hiding and the user folder)
import numpy as np  # noqa: E402

report = {"steps": {}, "renders": {}}
REPO_ID = "user_default"
MODULE = f"bl_ext.{REPO_ID}.lantern"


def run_step(name, fn):
    """Records fn's return value, or its error (the steps after it still run)."""
    t0 = time.perf_counter()
    try:
        report["steps"][name] = {"ok": True, "value": fn()}
    except Exception as error:
        report["steps"][name] = {"ok": False, "error": f"{type(error).__name__}: {error}",
                                 "traceback": traceback.format_exc()}
    report["steps"][name]["seconds"] = time.perf_counter() - t0


def files_under(root):
    return sorted(os.path.relpath(os.path.join(d, f), root)
                  for d, _, names in os.walk(root) for f in names)


def python_threads():
    return sorted(t.name for t in threading.enumerate())


def native_threads():
    names = []
    for task in os.listdir("/proc/self/task"):
        with open(f"/proc/self/task/{task}/comm") as f:
            names.append(f.read().strip())
    return sorted(names)


def child_processes():
    me, children = str(os.getpid()), []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[1] == me:
            children.append(int(pid))
    return children


def setup_render(scene):
    scene.render.engine = "LANTERN"
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"


def f12(name, scene):
    """F12 of `scene` into OUT/name.exr; the record holds its time and any error."""
    scene.render.filepath = os.path.join(OUT, name + ".exr")
    record = {"file": scene.render.filepath}
    t0 = time.perf_counter()
    try:
        bpy.ops.render.render(write_still=True)
    except RuntimeError as error:
        record["error"] = str(error).strip()
    record["seconds"] = time.perf_counter() - t0
    report["renders"][name] = record
    return record


# --- the checks -----------------------------------------------------------------------

def check_hidden_modules():
    importable = []
    for name in (*NOT_IN_BLENDER, "moderngl", "glcontext"):
        try:
            __import__(name)
            importable.append(name)
        except ImportError:
            pass
    return {"importable": importable}


def check_install():
    t0 = time.perf_counter()
    result = bpy.ops.extensions.package_install_files(
        filepath=ZIP, repo=REPO_ID, enable_on_install=True)
    seconds = time.perf_counter() - t0
    from pxr import Usd
    package = sys.modules[MODULE]
    # Found, not imported: the engine (and its GL) lives in the host's process.
    moderngl = importlib.util.find_spec("moderngl").origin
    return {"result": sorted(result), "seconds": seconds,
            "enabled": MODULE in bpy.context.preferences.addons,
            "package_file": package.__file__, "user_dir": USER, "moderngl": moderngl,
            "pxr": Usd.__file__, "blender_pxr_dir": bpy.utils.resource_path("LOCAL")}


def host_module():
    return sys.modules[MODULE + ".addon.host"]


def check_engine_process():
    """After the corpus renders: the host process Blender started, and what it runs."""
    host = host_module().get()
    return {"running": host.running(), "info": host.info, "executable": sys.executable,
            "children": child_processes(),
            "gl_in_blender": [m for m in ("moderngl", "glcontext") if m in sys.modules],
            "segments": shared_memory()}


def shared_memory():
    """Lantern's shared-memory blocks alive on this machine (POSIX shm)."""
    return sorted(f for f in os.listdir("/dev/shm") if f.startswith(f"lantern_{os.getpid()}_"))


def check_corpus():
    for path, name in ((os.path.join(CORPUS, "blender", "04_lights.blend"), "lights"),
                       (os.path.join(CORPUS, "blender", "02_suzanne.blend"), "suzanne"),
                       (os.path.join(CORPUS, "blender", "03_skinned_cylinder.blend"), "rig"),
                       (DEMO, "demo")):
        bpy.ops.wm.open_mainfile(filepath=path, load_ui=False)
        scene = bpy.context.scene
        setup_render(scene)
        f12(name, scene)


def two_object_scene():
    """A sphere left in collection A, a cube right in collection B, a sun and a camera in
    the scene's own collection; view layer A excludes B and view layer B excludes A."""
    bpy.ops.wm.read_homefile(use_empty=True)  # keeps the preferences (add-ons) loaded
    scene = bpy.context.scene
    for name, x, make in (("A", -2.0, bpy.ops.mesh.primitive_uv_sphere_add),
                          ("B", 2.0, bpy.ops.mesh.primitive_cube_add)):
        collection = bpy.data.collections.new(name)
        scene.collection.children.link(collection)
        make(location=(x, 0.0, 0.0))
        ob = bpy.context.active_object
        for c in ob.users_collection:
            c.objects.unlink(ob)
        collection.objects.link(ob)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.2, 0.0)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0.0, -10.0, 0.0), (1.5707963, 0.0, 0.0)
    for ob in (sun, camera):
        scene.collection.objects.link(ob)
    scene.camera = camera
    setup_render(scene)
    return scene


def check_view_layers():
    scene = two_object_scene()
    first = scene.view_layers[0]
    first.name = "LayerA"
    second = scene.view_layers.new("LayerB")
    first.layer_collection.children["B"].exclude = True
    second.layer_collection.children["A"].exclude = True
    scene.render.film_transparent = True
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    f12("layers", scene)


def check_film_border_resolution():
    scene = two_object_scene()
    f12("full", scene)
    scene.render.film_transparent = True
    f12("transparent", scene)
    scene.render.film_transparent = False
    render = scene.render
    render.use_border = True
    render.border_min_x, render.border_max_x = 0.1, 0.45  # over the sphere
    render.border_min_y, render.border_max_y = 0.2, 0.8
    render.use_crop_to_border = False
    f12("border", scene)
    render.use_crop_to_border = True
    f12("crop", scene)
    render.use_border = False
    render.resolution_percentage = 50
    f12("half", scene)
    return {"border": [render.border_min_x, render.border_min_y,
                       render.border_max_x, render.border_max_y]}


def check_animation():
    bpy.ops.wm.open_mainfile(filepath=os.path.join(CORPUS, "blender", "03_skinned_cylinder.blend"),
                             load_ui=False)
    scene = bpy.context.scene
    setup_render(scene)
    # Direct light: this checks ten frames through Render Animation and a rig that
    # moves; the bounce's field, rebuilt at each frame of a moving rig, made them about
    # ten times slower (the bounce over an animation: test_f12's one-session test).
    scene.cycles.max_bounces = 0
    scene.frame_start, scene.frame_end = 1, 10
    scene.render.filepath = os.path.join(OUT, "anim", "frame_####")
    t0 = time.perf_counter()
    bpy.ops.render.render(animation=True)
    return {"seconds": time.perf_counter() - t0,
            "files": sorted(os.listdir(os.path.join(OUT, "anim")))}


def check_stats_and_errors():
    scene = two_object_scene()
    stats = []

    def on_stats(text):
        stats.append(str(text))

    bpy.app.handlers.render_stats.append(on_stats)
    try:
        f12("stats", scene)
    finally:
        bpy.app.handlers.render_stats.remove(on_stats)
    # The engine process killed while it renders: one clear error, and the next F12
    # starts a new process and renders.
    host = host_module().get()
    first = host.info["pid"]

    def kill_while_rendering(text):
        if "Rendering" in str(text):
            host.kill()

    bpy.app.handlers.render_stats.append(kill_while_rendering)
    try:
        failed = f12("killed", scene)
    finally:
        bpy.app.handlers.render_stats.remove(kill_while_rendering)
    again = f12("recovered", scene)
    return {"stats": stats, "error": failed.get("error"), "recovered": again.get("error"),
            "pids": [first, host.info["pid"]]}


def check_material_preview():
    """Blender renders a material preview on its preview scene in a job thread; in
    background mode that job never reports finished, so this waits for Lantern's
    render() to return, then for the job to copy the frame into the preview (reading
    the preview while render() runs Python could wait on the job while holding the GIL)."""
    scene = two_object_scene()
    host_class = host_module().Host
    engine = sys.modules[MODULE + ".addon.render_engine"]
    render_request, render_frame = host_class.render, engine.render_frame
    calls, returned = [], threading.Event()

    def spy_request(host, scene_name, **request):
        calls.append({"scene": scene_name, "preset": request["preset"],
                      "size": [request["width"], request["height"]]})
        return render_request(host, scene_name, **request)

    def spy_frame(render_engine, depsgraph):
        try:
            render_frame(render_engine, depsgraph)
        finally:
            returned.set()

    host_class.render, engine.render_frame = spy_request, spy_frame
    previews = {}
    try:
        for name, colour in (("red", (0.8, 0.05, 0.05, 1.0)), ("blue", (0.05, 0.05, 0.8, 1.0)),
                             ("network", None)):
            material = bpy.data.materials.new(name)
            base = material.node_tree.nodes["Principled BSDF"].inputs["Base Color"]
            if colour is not None:
                base.default_value = colour
            else:
                # A node network (its fallback is the socket's grey): red and blue
                # cells of a Checker Texture on Generated coordinates.
                checker = material.node_tree.nodes.new("ShaderNodeTexChecker")
                checker.inputs["Color1"].default_value = (0.8, 0.05, 0.05, 1.0)
                checker.inputs["Color2"].default_value = (0.05, 0.05, 0.8, 1.0)
                checker.inputs["Scale"].default_value = 3.0
                material.node_tree.links.new(checker.outputs["Color"], base)
            returned.clear()
            t0 = time.perf_counter()
            with bpy.context.temp_override(id=material):
                bpy.ops.ed.lib_id_generate_preview()
            if not returned.wait(60):
                raise TimeoutError(f"no preview render for {name} in 60 s")
            preview = material.preview
            # The job copies the frame into the preview while this reads it: a read can
            # catch the copy half done. Done is non-empty and the same on two reads.
            pixels = None
            while time.perf_counter() - t0 < 60:
                now = np.array(preview.image_pixels_float[:], dtype=np.float32)
                if now.any() and pixels is not None and np.array_equal(now, pixels):
                    break
                pixels = now
                time.sleep(0.02)
            w, h = preview.image_size
            np.save(os.path.join(OUT, f"preview_{name}.npy"), pixels.reshape(h, w, 4))
            previews[name] = time.perf_counter() - t0
    finally:
        host_class.render, engine.render_frame = render_request, render_frame
    return {"calls": calls, "seconds": previews, "scene_engine": scene.render.engine}


def lantern_threads():
    return [name for name in python_threads() if name.startswith("lantern")]


def check_lifecycle():
    """Disable, enable, reinstall and uninstall: no thread, process or file left."""
    life = {"before_disable": lantern_threads(), "native_before_disable": native_threads(),
            "children_before_disable": child_processes(),
            "segments_before_disable": shared_memory()}
    bpy.ops.preferences.addon_disable(module=MODULE)
    life["after_disable"] = {"python_threads": python_threads(),
                             "native_threads": native_threads(),
                             "child_processes": child_processes(),
                             "segments": shared_memory(),
                             "enabled": MODULE in bpy.context.preferences.addons}
    bpy.ops.preferences.addon_enable(module=MODULE)
    scene = two_object_scene()
    life["reenabled_render"] = f12("reenabled", scene).get("error")
    bpy.ops.extensions.package_install_files(filepath=ZIP, repo=REPO_ID, enable_on_install=True)
    scene = two_object_scene()
    life["reinstalled_render"] = f12("reinstalled", scene).get("error")
    life["after_reinstall"] = lantern_threads()
    life["children_after_reinstall"] = child_processes()
    life["files_before_uninstall"] = files_under(HOME)
    repo_index = [r.module for r in bpy.context.preferences.extensions.repos].index(REPO_ID)
    bpy.ops.extensions.package_uninstall(repo_index=repo_index, pkg_id="lantern")
    life["after_uninstall"] = {"python_threads": python_threads(),
                               "native_threads": native_threads(),
                               "child_processes": child_processes(),
                               "segments": shared_memory(),
                               "files": files_under(HOME),
                               "enabled": MODULE in bpy.context.preferences.addons}
    return life


report["home"] = HOME
report["user_dir"] = os.path.relpath(USER, HOME)
report["baseline"] = {"files": files_under(HOME), "python_threads": python_threads(),
                      "native_threads": native_threads()}
for name in ("hidden_modules", "install", "corpus", "engine_process", "view_layers",
             "film_border_resolution",
             "animation", "stats_and_errors", "material_preview", "lifecycle"):
    run_step(name, globals()["check_" + name])

with open(os.path.join(OUT, "report.json"), "w") as f:
    json.dump(report, f, indent=1)
shutil.rmtree(HOME, ignore_errors=True)
