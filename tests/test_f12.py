"""F12 inside Blender: the pixels `lantern render` gives on the exported file, and the
body of RenderEngine.render (its result, progress, Esc, errors) with a recording engine."""
import subprocess
import sys

import calibration
import numpy as np
import pytest

WIDTH, HEIGHT = 96, 54


@pytest.fixture(scope="module")
def addon():
    import lantern
    lantern.register()
    yield
    lantern.unregister()


def _lantern(*args):
    proc = subprocess.run([sys.executable, "-m", "lantern", *args], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return proc


def _f12_and_cli(tmp_path, rigged):
    """The demo rendered by F12 and by `lantern render` on its exported file."""
    import bpy
    from lantern.demo.build_scene import build
    from lantern.engine.image_io import read_exr

    blend = tmp_path / "demo.blend"
    build(str(blend), rigged=rigged)
    scene = bpy.context.scene
    scene.render.engine = 'LANTERN'
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.filepath = str(tmp_path / "f12.exr")
    bpy.ops.render.render(write_still=True)
    f12 = read_exr(str(tmp_path / "f12.exr"))

    # The CLI side: export in one process, render in another that never imports bpy;
    # the demo's Suzanne subdivided as F12 does by default (Blender applies it).
    _lantern("export", str(blend), "-o", str(tmp_path / "demo.usda"), "--subdivision", "apply")
    _lantern("render", str(tmp_path / "demo.usda"), "-o", str(tmp_path / "cli.exr"),
             "--frame", str(scene.frame_current), "--size", f"{WIDTH}x{HEIGHT}")
    cli = read_exr(str(tmp_path / "cli.exr"))
    return f12, cli


def test_f12_equals_the_cli_on_the_exported_file(addon, tmp_path):
    """Static scenes: the in-memory stage F12 renders is the stage the file holds."""
    f12, cli = _f12_and_cli(tmp_path, rigged=False)
    assert f12.shape == cli.shape == (HEIGHT, WIDTH, 4)
    assert f12[..., :3].max() > 0.01, "F12 rendered black"
    difference = np.abs(f12 - cli).max()
    print(f"max |F12 - CLI| = {difference:.2e}")
    assert difference <= 1e-3


def test_f12_of_a_rig_differs_only_on_the_skinned_mesh(addon, tmp_path):
    """A known difference, kept small: F12 exports the render depsgraph as a still, so a
    rig arrives deformed by Blender, with normals recomputed after deformation; the file
    holds UsdSkel, whose skinned normals (and joint-padded bounds, which fit the sun's
    cascades) differ. Points agree to 1e-7 of the bbox (tests/test_skel_parity.py)."""
    f12, cli = _f12_and_cli(tmp_path, rigged=True)
    difference = np.abs(f12 - cli)[..., :3].max(axis=-1)
    print(f"rigged demo: {(difference > 1e-3).mean():.2%} of pixels differ, max {difference.max():.3f}")
    assert (difference > 1e-3).mean() < 0.05


def test_f12_renders_the_combined_pass_in_scene_linear(addon, tmp_path):
    """A 2 W/m² sun on a white Lambert plane reads 2·cos θ/π, not a display value."""
    import bpy
    from lantern.engine.image_io import read_exr

    scene = calibration.build_scene("sun")
    scene.render.engine = 'LANTERN'
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.filepath = str(tmp_path / "sun.exr")
    bpy.ops.render.render(write_still=True)
    image = read_exr(str(tmp_path / "sun.exr"))
    expected = calibration.closed_form_radiance("sun")
    assert np.allclose(image[..., 0], expected, rtol=0.02)


def test_export_operator_writes_the_same_stage_as_the_cli(addon, corpus, tmp_path):
    """File > Export > Lantern USD goes through the same exporter as `lantern export`."""
    import bpy
    from pxr import Usd, UsdSkel
    from lantern.exporters import open_blend, validation_errors

    open_blend(str(corpus / "blender" / "03_skinned_cylinder.blend"))
    out = tmp_path / "operator.usda"
    assert bpy.ops.export_scene.lantern_usd(filepath=str(out), limit_influences=True,
                                            max_influences=2) == {'FINISHED'}
    _lantern("export", str(corpus / "blender" / "03_skinned_cylinder.blend"),
             "-o", str(tmp_path / "cli.usda"), "--max-influences", "2")
    operator, cli = Usd.Stage.Open(str(out)), Usd.Stage.Open(str(tmp_path / "cli.usda"))
    assert validation_errors(operator) == []
    skinned = [p for p in operator.Traverse() if p.HasAPI(UsdSkel.BindingAPI)
               and UsdSkel.BindingAPI(p).GetJointIndicesPrimvar()]
    assert skinned and all(UsdSkel.BindingAPI(p).GetJointIndicesPrimvar().GetElementSize() <= 2
                           for p in skinned)
    assert [str(p.GetPath()) for p in operator.Traverse()] == [str(p.GetPath()) for p in cli.Traverse()]


def _passes_scene():
    """The sun calibration scene (an orthographic camera 10 m above a white plane,
    looking straight down), two cubes standing on the plane with object pass indices
    1 and 2, the second with a material of pass index 5, and every pass Lantern
    computes switched on."""
    import bpy
    from lantern.core.passes import provided
    scene = calibration.build_scene("sun")
    glow = bpy.data.materials.new("glow")
    glow.pass_index = 5
    for index, x in ((1, -2.0), (2, 2.0)):
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=(x, 0.0, 0.5))
        cube = bpy.context.object
        cube.pass_index = index
        if index == 2:
            cube.data.materials.append(glow)
    layer = bpy.context.view_layer
    for p in provided():
        setattr(layer, p.view_layer, True)
    return scene


def test_f12_writes_every_pass_the_view_layer_asks_for(addon, tmp_path):
    """Depth is the camera distance to the plane, Normal the plane's, IndexOB tells
    the objects apart and IndexMA the materials; in a multilayer EXR Blender wrote,
    under Blender 5's pass names, with the Cryptomatte metadata."""
    import bpy
    from lantern.addon.scene_render import blender_name
    from lantern.core.passes import provided
    from multilayer_exr import read_parts
    import cryptomatte_reader
    scene = _passes_scene()
    scene.render.engine = 'LANTERN'
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'
    scene.render.image_settings.color_depth = '32'
    scene.render.filepath = str(tmp_path / "passes.exr")
    bpy.ops.render.render(write_still=True)
    parts = read_parts(tmp_path / "passes.exr")
    layer = bpy.context.view_layer.name
    for p in provided():
        assert f"{layer}.{blender_name(p.name)}" in parts, (p.name, sorted(parts))
    assert {f"{layer}.Diffuse Indirect", f"{layer}.Glossy Indirect"} <= set(parts)
    depth, normal = parts[f"{layer}.Depth"], parts[f"{layer}.Normal"]
    ob, ma = parts[f"{layer}.Object Index"], parts[f"{layer}.Material Index"]
    depth, ob, ma = (a.reshape(a.shape[:2]) for a in (depth, ob, ma))
    plane = ob == 0
    size = calibration.SIZE
    assert depth.shape[:2] == (size, size) and plane.mean() > 0.8
    np.testing.assert_allclose(depth[plane], calibration.CAMERA_HEIGHT, rtol=1e-5)
    assert (depth[~plane] < calibration.CAMERA_HEIGHT - 0.9).all()     # the cubes' tops
    np.testing.assert_allclose(normal[plane], np.broadcast_to((0, 0, 1), normal[plane].shape),
                               atol=1e-3)
    assert set(np.unique(ob)) == {0.0, 1.0, 2.0}
    assert set(np.unique(ma[ob == 2])) == {5.0} and set(np.unique(ma[ob != 2])) == {0.0}
    header, _ = cryptomatte_reader.read(tmp_path / "passes.exr")
    assert set(cryptomatte_reader.matte_types(header)) == {
        f"{layer}.CryptoObject", f"{layer}.CryptoMaterial", f"{layer}.CryptoAsset"}


def test_the_cli_on_the_exported_file_gives_what_f12_gives(addon, tmp_path):
    """The view layer's passes make the exported stage's RenderProduct: `lantern
    render scene.usda`, with no option, writes the file Blender's Render Animation
    would, and each pass equals F12's within float16 rounding."""
    import bpy
    from lantern.addon.scene_render import blender_name
    from lantern.core.passes import provided
    from multilayer_exr import read_parts
    scene = _passes_scene()
    scene.render.engine = 'LANTERN'
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'
    scene.render.image_settings.color_depth = '32'
    scene.render.filepath = str(tmp_path / "f12.exr")
    bpy.ops.render.render(write_still=True)
    f12 = read_parts(tmp_path / "f12.exr")
    scene.render.filepath = "//frames/shot_####"
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    _lantern("export", str(tmp_path / "scene.blend"), "-o", str(tmp_path / "scene.usda"))
    proc = subprocess.run([sys.executable, "-m", "lantern", "render", "scene.usda"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    cli = read_parts(tmp_path / "frames" / f"shot_{scene.frame_current:04d}.exr")
    layer = bpy.context.view_layer.name
    names = ["Combined"] + [blender_name(p.name) for p in provided()]
    assert sorted(cli) == sorted(f"{layer}.{n}" for n in names)
    for name in names:
        a, b = f12[f"{layer}.{name}"], cli[f"{layer}.{name}"]
        worst = float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-3)))
        print(f"{name}: worst difference {worst:.1e} of the value")
        assert worst <= 2.0 ** -11, name          # float16's rounding: half its step


# --- render_frame, the body of RenderEngine.render, driven by a recording engine ---------

class _Pixels:
    def __init__(self, size):
        self.size, self.data = size, None

    def foreach_set(self, values):
        if len(values) != self.size:  # as Blender's foreach_set
            raise TypeError(f"expected sequence size {self.size}, got {len(values)}")
        self.data = np.array(values, dtype=np.float32)


class RecordingEngine:
    """The RenderEngine methods render_frame uses, recorded in call order."""

    def __init__(self, width, height, test_break=lambda: False, is_preview=False):
        self.resolution_x, self.resolution_y, self.is_preview = width, height, is_preview
        self._test_break = test_break
        self.calls, self.pixels, self.stamps = [], {}, {}

    def test_break(self):
        return self._test_break()

    def update_stats(self, stats, info):
        self.calls.append(("stats", info))

    def update_progress(self, value):
        self.calls.append(("progress", value))

    def report(self, kind, message):
        self.calls.append(("report", *kind, message))

    def error_set(self, message):
        self.calls.append(("error_set", message))

    def begin_result(self, x, y, w, h, layer=""):
        from types import SimpleNamespace
        from lantern.addon.scene_render import blender_name
        from lantern.core.passes import PASSES
        self.calls.append(("begin_result", (x, y, w, h), layer))
        self.pixels = {name: _Pixels(w * h * (4 if name == "Combined" else PASSES[name].channels))
                       for name in ["Combined", *PASSES]}
        return SimpleNamespace(layers=[SimpleNamespace(passes={
            blender_name(name): SimpleNamespace(rect=pixels)
            for name, pixels in self.pixels.items()})])

    def get_result(self):
        from types import SimpleNamespace
        return SimpleNamespace(stamp_data_add_field=lambda field, value:
                               self.stamps.__setitem__(field, value))

    def end_result(self, result):
        self.calls.append(("end_result",))

    def kinds(self):
        return [c[0] for c in self.calls]

    def image(self, name="Combined"):
        """The pass as written, row 0 = top."""
        data = self.pixels[name].data
        return data.reshape(self.resolution_y, self.resolution_x, -1)[::-1]


def _in_process(depsgraph, size, passes=frozenset()):
    """The same frame rendered in this process, from the same export."""
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import stage_from_depsgraph
    stage, _ = stage_from_depsgraph(depsgraph)
    return render_stage(stage, RenderSettings(width=size, height=size, passes=passes,
                                              frame=depsgraph.scene.frame_current))


def test_render_frame_fills_this_layers_result_with_progress(addon):
    import bpy
    from lantern.addon.scene_render import render_frame
    _passes_scene()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    size = calibration.SIZE
    engine = RecordingEngine(size, size)
    render_frame(engine, depsgraph)
    assert ("begin_result", (0, 0, size, size), depsgraph.view_layer.name) in engine.calls
    assert engine.kinds()[-3:] == ["end_result", "progress", "stats"]
    progress = [c[1] for c in engine.calls if c[0] == "progress"]
    assert progress == sorted(progress) and progress[-1] == 1.0
    stats = [c[1] for c in engine.calls if c[0] == "stats"]
    assert stats[:2] == ["Exporting the scene", "Rendering"] and stats[-1].startswith("Done in")
    expected = _in_process(depsgraph, size, frozenset(["Depth", "IndexOB", "CryptoAsset00"]))
    np.testing.assert_allclose(engine.image(), expected.rgba, atol=1e-6)
    for name in ("Depth", "IndexOB", "CryptoAsset00", "CryptoAsset02"):
        np.testing.assert_array_equal(engine.image(name), expected.passes[name])
    # The mattes' metadata, on the render result as Cycles puts it.
    layer = depsgraph.view_layer.name
    assert {v for k, v in engine.stamps.items() if k.endswith("/name")} == {
        f"{layer}.CryptoObject", f"{layer}.CryptoMaterial", f"{layer}.CryptoAsset"}
    assert '"/root/Cube"' in next(v for k, v in engine.stamps.items()
                                  if k.endswith("/manifest") and "/root/Cube" in v)


def test_an_animation_reuses_one_session(addon):
    """Frame after frame of F12, the host's Session reads again only what moved: the
    stage is not rebuilt, no mesh goes up again, and each frame equals a fresh render."""
    import bpy
    from lantern.addon import host
    from lantern.addon.scene_render import render_frame
    scene = calibration.build_scene("sun")
    for i in range(12):
        bpy.ops.mesh.primitive_cube_add(size=0.5, location=(i % 4 - 1.5, i // 4 - 1.0, 0.25))
    mover = bpy.context.object
    mover.keyframe_insert("location", frame=1)
    mover.location.z = 2.0
    mover.keyframe_insert("location", frame=3)
    size, stats = 24, []
    for frame in (1, 2, 3):
        scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        engine = RecordingEngine(size, size)
        render_frame(engine, depsgraph)
        name = f"render:{scene.name_full}:{depsgraph.view_layer.name}"
        stats.append(host.get().channels[name].latest.stats)
        np.testing.assert_allclose(engine.image(), _in_process(depsgraph, size).rgba, atol=1e-6)
    assert stats[0]["prims_read"] > 1
    for later in stats[1:]:
        assert later["prims_read"] == 1 and later["meshes_uploaded"] == 0, later


def test_esc_drops_the_frame_without_waiting_for_it(addon):
    """test_break is polled while the host renders: the frame in flight is dropped at
    once (nothing written), and the next render goes on as usual."""
    import bpy
    from lantern.addon.scene_render import render_frame
    calibration.build_scene("sun")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    engine = RecordingEngine(16, 16, test_break=lambda: engine.kinds().count("stats") >= 2)
    render_frame(engine, depsgraph)
    assert "begin_result" not in engine.kinds() and "error_set" not in engine.kinds()
    assert ("stats", "Cancelled") in engine.calls
    again = RecordingEngine(16, 16)
    render_frame(again, depsgraph)
    assert "end_result" in again.kinds()


def test_a_killed_engine_is_reported_and_the_next_render_recovers(addon):
    """The engine process killed mid-render: one clear line in report and error_set,
    Blender goes on, and the next render starts a new process and succeeds."""
    import bpy
    from lantern.addon import host
    from lantern.addon.scene_render import render_frame
    calibration.build_scene("sun")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    size = calibration.SIZE
    render_frame(RecordingEngine(size, size), depsgraph)
    first = host.get().generation

    def kill_once():
        if engine.kinds().count("stats") >= 2:       # rendering
            host.get().kill()
        return False

    engine = RecordingEngine(size, size, test_break=kill_once)
    render_frame(engine, depsgraph)
    reports = [c for c in engine.calls if c[0] in ("report", "error_set")]
    assert ("error_set", "Lantern: the engine process stopped (killed by SIGKILL)") in reports, reports
    assert "begin_result" not in engine.kinds()
    again = RecordingEngine(size, size)
    render_frame(again, depsgraph)
    assert "end_result" in again.kinds() and host.get().generation == first + 1
    np.testing.assert_allclose(again.image(), _in_process(depsgraph, size).rgba, atol=1e-6)


def test_errors_go_to_report_and_error_set(addon, monkeypatch):
    """An engine that cannot start (here: no GL context in the child) is one line in
    report and error_set, never an exception in Blender."""
    import bpy
    from lantern.addon import host
    from lantern.addon.scene_render import render_frame
    calibration.build_scene("sun")
    host.shutdown()
    monkeypatch.setenv("MESA_GL_VERSION_OVERRIDE", "3.0")   # below the engine's GL 3.3
    monkeypatch.setattr(host, "RESTART_SECONDS", 0.0)
    engine = RecordingEngine(16, 16)
    render_frame(engine, bpy.context.evaluated_depsgraph_get())
    errors = [c[1] for c in engine.calls if c[0] == "error_set"]
    assert len(errors) == 1 and errors[0].startswith("Lantern: the engine could not get an "
                                                     "OpenGL context"), engine.calls
    assert "begin_result" not in engine.kinds()
    host.shutdown()
