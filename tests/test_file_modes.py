"""Outputs get the permissions the umask gives a new file (0666 less the umask), not
mkstemp's private 0600: images, sequence frames, GIFs, exported USD and the texture
copies beside it, and the compare report's files (its PNGs, heat maps, results.json and
index.html), under umask 022 and 077. Every writer goes through
core.files.atomic_write (a temporary name, then a rename)."""
import os
import stat
import subprocess
import sys

import numpy as np
import pytest

from lantern.core import files
from lantern.engine.image_io import write_animation, write_image


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture(params=[0o022, 0o077], ids=["umask022", "umask077"])
def umask(request):
    old = os.umask(request.param)
    yield request.param
    os.umask(old)


def test_atomic_writes_take_the_umask(tmp_path, umask):
    target = tmp_path / "a.txt"
    files.atomic_write(str(target), lambda tmp: open(tmp, "w").write("x"))
    assert _mode(target) == 0o666 & ~umask
    assert files.current_umask() == umask


def test_images_and_gifs_take_the_umask(tmp_path, umask):
    rgba = np.full((4, 6, 4), 0.5, np.float32)
    for name in ("x.png", "x.exr"):
        write_image(str(tmp_path / name), rgba)
        assert _mode(tmp_path / name) == 0o666 & ~umask, name
    write_animation(str(tmp_path / "x.gif"), [rgba, rgba], 24.0)
    assert _mode(tmp_path / "x.gif") == 0o666 & ~umask


def _lantern(args, umask):
    return subprocess.run([sys.executable, "-m", "lantern", *args], capture_output=True,
                          text=True, preexec_fn=lambda: os.umask(umask))


def test_exports_renders_and_sequences_take_the_umask(corpus, tmp_path, umask):
    usd = tmp_path / "mirror.usda"
    proc = _lantern(["export", str(corpus / "blender" / "09_tex_wrapping_mirror.blend"), "-o",
                     str(usd), "--textures", "copy"], umask)
    assert proc.returncode == 0, proc.stderr
    copies = list((tmp_path / "mirror_textures").iterdir())
    assert copies
    for path in [usd, *copies]:
        assert _mode(path) == 0o666 & ~umask, path
    proc = _lantern(["render", str(usd), "-o", str(tmp_path / "f_##.png"), "--frames", "1:2",
                     "--size", "16x9"], umask)
    assert proc.returncode == 0, proc.stderr
    for frame in ("f_01.png", "f_02.png"):
        assert _mode(tmp_path / frame) == 0o666 & ~umask, frame
    proc = _lantern(["render", str(usd), "-o", str(tmp_path / "one.exr"), "--size", "16x9"],
                    umask)
    assert proc.returncode == 0, proc.stderr
    assert _mode(tmp_path / "one.exr") == 0o666 & ~umask


def test_the_compare_reports_files_take_the_umask(tmp_path, umask):
    from lantern.compare import report
    from lantern.compare.files import write_json, write_text
    rgba = np.full((4, 6, 4), 0.5, np.float32)
    paths = [report.display_png(str(tmp_path / "png" / "a.png"), rgba,
                                {"transform": "Standard", "look": None, "exposure": 0.0}),
             report.heatmap_png(str(tmp_path / "png" / "flip_a.png"),
                                np.linspace(0, 1, 24, dtype=np.float32).reshape(4, 6))]
    write_json(str(tmp_path / "results.json"), {"a": 1})
    write_text(str(tmp_path / "index.html"), "<html></html>\n")
    paths += [tmp_path / "results.json", tmp_path / "index.html"]
    for path in paths:
        assert _mode(path) == 0o666 & ~umask, path
