"""export_blend: formats, atomic writes, and errors naming the file."""
import os
import pathlib

import pytest
from pxr import Sdf, Usd

from lantern.exporters import ExportError, ExportOptions, export_blend

CUBE = pathlib.Path(__file__).resolve().parent.parent.parent / "shared/corpus/blender/01_cube.blend"
TEXTURED = CUBE.with_name("01_principled_material.blend")


@pytest.mark.parametrize("ext, crate", [(".usda", False), (".usdc", True), (".usd", True)])
def test_output_format_follows_the_extension(tmp_path, ext, crate):
    out = tmp_path / ("scene" + ext)
    export_blend(str(CUBE), str(out))
    assert out.read_bytes().startswith(b"PXR-USDC") == crate
    assert Usd.Stage.Open(str(out)).GetPrimAtPath("/root/Cube")


def test_export_replaces_an_existing_file_whole(tmp_path):
    out = tmp_path / "scene.usda"
    out.write_text("old contents that are not USD\n" * 1000)
    report = export_blend(str(CUBE), str(out))
    text = out.read_text()
    assert text.startswith("#usda 1.0") and "old contents" not in text
    assert Sdf.Layer.FindOrOpen(str(out)) is not None
    assert report.path == str(out) and report.seconds > 0
    assert os.listdir(tmp_path) == ["scene.usda"]  # no temp file left behind


def test_missing_blend_raises_and_leaves_output_alone(tmp_path):
    out = tmp_path / "scene.usda"
    out.write_text("keep me")
    missing = tmp_path / "nope.blend"
    with pytest.raises(ExportError, match="nope.blend"):
        export_blend(str(missing), str(out))
    assert out.read_text() == "keep me"


def test_corrupt_blend_raises_naming_the_file(tmp_path):
    junk = tmp_path / "junk.blend"
    junk.write_bytes(os.urandom(4096))
    with pytest.raises(ExportError, match="junk.blend"):
        export_blend(str(junk), str(tmp_path / "out.usda"))
    assert not (tmp_path / "out.usda").exists()


def test_truncated_blend_raises_naming_the_file(tmp_path):
    cut = tmp_path / "cut.blend"
    data = CUBE.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ExportError, match="cut.blend"):
        export_blend(str(cut), str(tmp_path / "out.usda"))


def test_unknown_extension_raises(tmp_path):
    with pytest.raises(ExportError, match="out.obj"):
        export_blend(str(CUBE), str(tmp_path / "out.obj"))


def test_texture_copy_mode(tmp_path):
    out = tmp_path / "copied.usda"
    export_blend(str(TEXTURED), str(out), ExportOptions(textures="copy"))
    files = sorted(p.name for p in (tmp_path / "copied_textures").iterdir())
    assert "01_principled_baseColor.png" in files
    assert "@./copied_textures/01_principled_baseColor.png@" in out.read_text()


def test_export_is_deterministic(tmp_path):
    a, b = tmp_path / "a.usda", tmp_path / "b.usda"
    export_blend(str(TEXTURED), str(a))
    export_blend(str(TEXTURED), str(b))
    assert a.read_text() == b.read_text()
