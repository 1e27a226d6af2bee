"""Rigged corpus scenes: UsdSkel parity with Blender at every frame, and validation."""
import bpy
import pytest

from _export_helpers import parity
from lantern.exporters import stage_from_blend, validation_errors

RIGGED = ["03_skinned_cylinder", "29_armature_use_rest_pose", "29_armature_use_current_pose",
          "parent_is_skined", "28_shapekeys_anim", "01_morphed_cube", "03_animated_cube"]
SKELETONS = {"03_skinned_cylinder": 1, "29_armature_use_rest_pose": 1,
             "29_armature_use_current_pose": 1, "parent_is_skined": 2,
             "28_shapekeys_anim": 2, "01_morphed_cube": 1, "03_animated_cube": 0}


@pytest.mark.parametrize("name", RIGGED)
def test_corpus_rig_parity(corpus, name):
    stage, report = stage_from_blend(str(corpus / "blender" / f"{name}.blend"))
    assert validation_errors(stage) == []
    assert report.counts["skeletons"] == SKELETONS[name]
    assert report.counts["baked"] == 0, report.warnings
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH" and not o.hide_render]
    errors = parity(stage, meshes)
    print(f"\n{name}: worst {max(errors.values()):.2e}")
    assert max(errors.values()) <= 1e-5, errors
