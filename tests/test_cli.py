"""The command line: batch export that survives bad files, rendering without bpy."""
import os
import subprocess
import sys

import numpy as np


def _lantern(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "lantern", *args],
                          capture_output=True, text=True, cwd=cwd)


def test_batch_export_goes_on_past_bad_files(corpus, tmp_path):
    corrupt = tmp_path / "corrupt.blend"
    corrupt.write_bytes(b"BLENDER-v500" + os.urandom(2000))
    truncated = tmp_path / "truncated.blend"
    truncated.write_bytes((corpus / "blender" / "01_cube.blend").read_bytes()[:3000])
    good = corpus / "blender" / "01_cube.blend"
    out = tmp_path / "out"
    proc = _lantern("export", str(good), str(corrupt), str(truncated),
                    str(tmp_path / "missing.blend"), "-o", str(out), "-j", "2")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert (out / "01_cube.usdc").is_file()
    assert sorted(os.listdir(out)) == ["01_cube.usdc"], "a failed file left something behind"
    for name in ("corrupt.blend", "truncated.blend", "missing.blend"):
        assert name in proc.stdout, f"{name} missing from the summary:\n{proc.stdout}"
    assert "1 exported, 3 failed" in proc.stdout


def test_single_export_and_render_png_without_bpy(corpus, tmp_path):
    usd = tmp_path / "cube.usda"
    proc = _lantern("export", str(corpus / "blender" / "01_cube.blend"), "-o", str(usd))
    assert proc.returncode == 0, proc.stderr
    png = tmp_path / "cube.png"
    # The render process must not import bpy: prove it by making bpy unimportable there.
    blocker = tmp_path / "nobpy"
    blocker.mkdir()
    (blocker / "bpy.py").write_text("raise ImportError('bpy must not be imported by lantern render')\n")
    env = dict(os.environ, PYTHONPATH=str(blocker))
    proc = subprocess.run([sys.executable, "-m", "lantern", "render", str(usd), "-o", str(png),
                           "--size", "64x36", "--debug"], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    # --debug names the GL the engine got and the paths it took.
    assert "GL: " in proc.stdout and "asked for" in proc.stdout and "paths: " in proc.stdout
    import imageio.v3 as iio
    pixels = iio.imread(png)
    assert pixels.shape[:2] == (36, 64)
    assert pixels[..., :3].max() > 0


def test_render_a_blend_directly(corpus, tmp_path):
    exr = tmp_path / "cube.exr"
    proc = _lantern("render", str(corpus / "blender" / "01_cube.blend"), "-o", str(exr),
                    "--size", "32x18")
    assert proc.returncode == 0, proc.stderr
    from lantern.engine.image_io import read_exr
    assert np.isfinite(read_exr(str(exr))).all()


def test_bad_arguments_get_clear_messages(tmp_path):
    proc = _lantern("render", str(tmp_path / "nothing.usda"), "-o", str(tmp_path / "x.exr"))
    assert proc.returncode == 1 and "nothing.usda" in proc.stderr
    proc = _lantern("render", str(tmp_path / "nothing.usda"), "-o", str(tmp_path / "x.jpg"))
    assert proc.returncode == 2 and ".exr or .png" in proc.stderr
    proc = _lantern("export", "a.txt", "-o", str(tmp_path / "a.usda"))
    assert proc.returncode == 2 and "not a .blend" in proc.stderr
    proc = _lantern("render", "x.usda", "-o", "x.exr", "--size", "big")
    assert proc.returncode == 2 and "--size" in proc.stderr


def test_max_influences_option_trims_exported_influences(corpus, tmp_path):
    from pxr import Usd, UsdSkel
    out = tmp_path / "cylinder.usda"
    proc = _lantern("export", str(corpus / "blender" / "03_skinned_cylinder.blend"), "-o", str(out),
                    "--max-influences", "1")
    assert proc.returncode == 0, proc.stderr
    stage = Usd.Stage.Open(str(out))
    sizes = [UsdSkel.BindingAPI(p).GetJointIndicesPrimvar().GetElementSize()
             for p in stage.Traverse() if p.HasAPI(UsdSkel.BindingAPI)
             and UsdSkel.BindingAPI(p).GetJointIndicesPrimvar()]
    assert sizes and all(size == 1 for size in sizes), sizes
    assert _lantern("export", "x.blend", "-o", str(out), "--max-influences", "0").returncode == 2
