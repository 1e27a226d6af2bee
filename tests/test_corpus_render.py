"""Every scene of the shared corpus exports and renders: no exception, no NaN or Inf."""
import pathlib

import numpy as np
import pytest

CORPUS_BLENDS = sorted((pathlib.Path(__file__).resolve().parent.parent.parent
                        / "shared" / "corpus" / "blender").glob("*.blend"))


def _world_image_paths():
    import bpy
    world = bpy.context.scene.world
    if world is None or world.node_tree is None:
        return []
    return [node.image.filepath for node in world.node_tree.nodes
            if node.type == 'TEX_ENVIRONMENT' and node.image is not None]


@pytest.mark.parametrize("blend", CORPUS_BLENDS, ids=lambda p: p.stem)
def test_corpus_scene_exports_and_renders(blend):
    import bpy
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import stage_from_blend

    stage, report = stage_from_blend(str(blend))
    result = render_stage(stage, RenderSettings(width=48, height=27))
    assert result.rgba.shape == (27, 48, 4)
    assert np.isfinite(result.rgba).all(), f"{blend.name}: NaN or Inf in the image"
    assert result.rgba[..., :3].max() > 0.0, f"{blend.name}: black image"

    missing = [path for path in _world_image_paths()
               if not pathlib.Path(bpy.path.abspath(path)).is_file()]
    for path in missing:
        name = pathlib.PurePath(path).name
        assert any(name in w for w in report.warnings), \
            f"{blend.name}: no warning about the missing world image {path}: {report.warnings}"


def test_the_corpus_has_a_missing_world_texture_case():
    """The warning check above is exercised: some corpus scenes miss field.hdr."""
    import bpy
    from lantern.exporters import open_blend
    hits = 0
    for blend in CORPUS_BLENDS:
        open_blend(str(blend))
        hits += any("field.hdr" in path for path in _world_image_paths())
    assert hits > 0
