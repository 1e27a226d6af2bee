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

    # The CLI side: export in one process, render in another that never imports bpy.
    _lantern("export", str(blend), "-o", str(tmp_path / "demo.usda"))
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
        self.calls, self.pixels = [], None

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
        self.calls.append(("begin_result", (x, y, w, h), layer))
        self.pixels = _Pixels(w * h * 4)
        return SimpleNamespace(layers=[SimpleNamespace(passes={"Combined": SimpleNamespace(
            rect=self.pixels)})])

    def end_result(self, result):
        self.calls.append(("end_result",))

    def kinds(self):
        return [c[0] for c in self.calls]


def test_render_settings_come_from_the_scene(addon):
    from lantern.addon.scene_render import render_settings
    scene = calibration.build_scene("sun")
    scene.lantern.preset, scene.render.film_transparent, scene.frame_current = "high", True, 7
    s = render_settings(scene, 32, 18)
    assert (s.width, s.height, s.preset, s.transparent, s.frame) == (32, 18, "high", True, 7.0)
    assert render_settings(scene, 32, 18, preview=True).preset == "low"


def test_render_frame_fills_this_layers_result_with_progress(addon):
    import bpy
    from lantern.addon.scene_render import render_final, render_frame
    calibration.build_scene("sun")
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
    expected, _ = render_final(depsgraph, size, size)
    np.testing.assert_allclose(engine.pixels.data.reshape(size, size, 4), expected[::-1], atol=1e-6)


def test_esc_drops_the_frame_without_waiting_for_it(addon, monkeypatch):
    """test_break is polled while the engine renders: the frame in flight is dropped at
    once (nothing written), and finishes on its own; shutdown() waits for it."""
    import threading
    import time
    import bpy
    from lantern.addon import scene_render
    calibration.build_scene("sun")
    started, finished = threading.Event(), threading.Event()
    real = scene_render.render_stage

    def slow_render(stage, settings):
        started.set()
        time.sleep(0.5)
        try:
            return real(stage, settings)
        finally:
            finished.set()

    monkeypatch.setattr(scene_render, "render_stage", slow_render)
    engine = RecordingEngine(16, 16, test_break=started.is_set)
    scene_render.render_frame(engine, bpy.context.evaluated_depsgraph_get())
    assert started.is_set() and not finished.is_set()  # returned while the frame renders
    assert "begin_result" not in engine.kinds() and "error_set" not in engine.kinds()
    assert ("stats", "Cancelled") in engine.calls
    scene_render.shutdown()
    assert finished.is_set()
    assert not [t.name for t in threading.enumerate() if t.name.startswith("lantern")]


def test_errors_go_to_report_and_error_set(addon, monkeypatch):
    import bpy
    from lantern.addon import scene_render
    calibration.build_scene("sun")

    def broken(stage, settings):
        raise RuntimeError("no headless OpenGL 3.3 context")

    monkeypatch.setattr(scene_render, "render_stage", broken)
    engine = RecordingEngine(16, 16)
    scene_render.render_frame(engine, bpy.context.evaluated_depsgraph_get())
    message = "Lantern: no headless OpenGL 3.3 context"
    assert ("report", "ERROR", message) in engine.calls and ("error_set", message) in engine.calls
    assert "begin_result" not in engine.kinds()
