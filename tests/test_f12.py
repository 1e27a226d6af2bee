"""F12 inside Blender gives the pixels `lantern render` gives on the exported file."""
import subprocess
import sys

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
    import calibration
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
