"""Every corpus scene exports, opens and validates."""
import pathlib

import pytest
from pxr import Usd, UsdGeom

from lantern.exporters import export_blend, validation_errors

CORPUS_BLENDS = sorted((pathlib.Path(__file__).resolve().parent.parent.parent
                        / "shared" / "corpus" / "blender").glob("*.blend"))


def _uses_field_hdr(path):
    # The world's Environment Texture path is stored verbatim in the file.
    return b"field.hdr" in path.read_bytes()


def test_corpus_is_present():
    assert len(CORPUS_BLENDS) >= 20


@pytest.mark.parametrize("blend", CORPUS_BLENDS, ids=lambda p: p.stem)
def test_corpus_scene_exports_and_validates(blend, tmp_path):
    out = tmp_path / (blend.stem + ".usda")
    report = export_blend(str(blend), str(out))
    assert report.path == str(out)
    stage = Usd.Stage.Open(str(out))
    assert stage is not None
    assert stage.GetDefaultPrim().GetPath() == "/root"
    assert validation_errors(stage) == []
    # One prim per exported object: everything named from Blender except mesh data,
    # materials and the world.
    objects = [p for p in stage.Traverse() if p.HasAttribute("lantern:blenderName")
               and not p.GetPath().pathString.startswith("/root/_") and not p.IsA(UsdGeom.Mesh)]
    assert report.counts["objects"] == len(objects) > 0
    if _uses_field_hdr(blend):
        assert any("world 'World'" in w and "field.hdr" in w for w in report.warnings), \
            report.warnings
        dome = stage.GetPrimAtPath("/root/_world")
        assert dome and not dome.GetAttribute("inputs:texture:file").HasAuthoredValue()


def test_field_hdr_scenes_exist():
    assert sum(_uses_field_hdr(p) for p in CORPUS_BLENDS) >= 5
