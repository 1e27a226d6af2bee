"""The indirect light's render passes, DiffInd and GlossInd (core/passes.py), on the
closed box of tests/shot_scenes.py (an area light in the ceiling, Cycles' default
bounces): with the direct passes they add up to the image; the ceiling, which only
bounced light reaches, is in DiffInd and not in DiffDir, as Cycles splits it; in direct
mode they are there and 0, as Cycles writes an enabled pass it has no light for; and
`lantern render --passes` writes them under Blender's names. The glossy bounce's split
is tests/test_reflections.py's. Needs compute shaders (GL 4.3), as the field does."""
import numpy as np
import pytest

import shot_scenes
from multilayer_exr import read_parts
from test_render_products import lantern

W, H = 80, 60
LIGHT = ("DiffDir", "DiffInd", "GlossDir", "GlossInd", "Env", "Emit")
# The ceiling is lit by bounced light only: the area light under it faces down.
CEILING_NORMAL_Z = -0.9


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    """(the exported stage, its file, the Blender scene): the closed box at W x H."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    scene = shot_scenes.build("cornell_box")
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert report.warnings == []
    path = tmp_path_factory.mktemp("box") / "box.usda"
    stage.GetRootLayer().Export(str(path))
    return stage, path, scene


@pytest.fixture(scope="module")
def rendered(box):
    """{bounces: RenderResult} with the light passes and the normals: the stage's
    bounces (Cycles' defaults, as exported) and direct mode."""
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    names = frozenset(LIGHT + ("Normal",))
    return {mode: render_stage(box[0], RenderSettings(width=W, height=H, preset="medium",
                                                      fxaa=False, passes=names, bounces=b))
            for mode, b in (("full", None), ("direct", DIRECT))}


def _ceiling(result):
    return result.passes["Normal"][..., 2] < CEILING_NORMAL_Z


@pytest.mark.parametrize("mode", ["full", "direct"])
def test_the_light_passes_add_up_to_the_image(rendered, mode):
    result = rendered[mode]
    assert ("irradiance" in result.stats["passes"]) == (mode == "full")
    total = sum(result.passes[n] for n in LIGHT)
    np.testing.assert_allclose(total, result.rgba[..., :3], rtol=2.0 ** -11, atol=1e-6)


def test_the_ceiling_is_lit_by_bounced_light_only(rendered):
    full, direct = rendered["full"], rendered["direct"]
    ceiling = _ceiling(full)
    assert ceiling.sum() > 100
    print(f"ceiling: DiffDir {full.passes['DiffDir'][ceiling].mean():.4f}, "
          f"DiffInd {full.passes['DiffInd'][ceiling].mean():.4f}")
    assert full.passes["DiffInd"][ceiling].mean() > 0.1
    assert full.passes["DiffDir"][ceiling].max() < 1e-3
    # The walls' direct light is the same with or without the bounce: the bounce is
    # all in DiffInd.
    np.testing.assert_allclose(full.passes["DiffDir"], direct.passes["DiffDir"], atol=1e-6)


def test_in_direct_mode_the_indirect_passes_are_there_and_zero(rendered):
    direct = rendered["direct"]
    for name in ("DiffInd", "GlossInd"):
        assert direct.passes[name].shape == (H, W, 3)
        assert not direct.passes[name].any(), name


def test_the_split_is_cycles_split(box, rendered, tmp_path):
    """Cycles at 16 samples, Diffuse Direct and Indirect times Diffuse Color (Lantern's
    passes hold the albedo): the image's mean of each, and the ceiling's, within 10%."""
    import bpy
    _, _, scene = box
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.use_denoising = 16, False
    layer = bpy.context.view_layer
    for name in ("diffuse_direct", "diffuse_indirect", "diffuse_color"):
        setattr(layer, f"use_pass_{name}", True)
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(tmp_path / "cycles.exr")
    bpy.ops.render.render(write_still=True)
    parts = read_parts(tmp_path / "cycles.exr")
    colour = parts[f"{layer.name}.Diffuse Color"][..., :3]
    full = rendered["full"]
    ceiling = _ceiling(full)
    for name, title in (("DiffDir", "Diffuse Direct"), ("DiffInd", "Diffuse Indirect")):
        cycles = parts[f"{layer.name}.{title}"][..., :3] * colour
        ours = full.passes[name]
        print(f"{name}: image {ours.mean():.4f} (Cycles {cycles.mean():.4f}), "
              f"ceiling {ours[ceiling].mean():.4f} (Cycles {cycles[ceiling].mean():.4f})")
        assert abs(ours.mean() / cycles.mean() - 1.0) < 0.1, name
        if name == "DiffInd":
            assert abs(ours[ceiling].mean() / cycles[ceiling].mean() - 1.0) < 0.1
        else:
            assert cycles[ceiling].mean() < 1e-3


def test_lantern_render_writes_them_under_blenders_names(box, tmp_path):
    out = tmp_path / "passes.exr"
    proc = lantern("render", box[1], "-o", out, "--size", f"{W}x{H}",
                   "--passes", "diffuse_direct,diffuse_indirect,glossy_indirect")
    assert proc.returncode == 0, proc.stderr
    parts = read_parts(out)
    assert set(parts) == {f"ViewLayer.{n}" for n in ("Combined", "Diffuse Direct",
                                                     "Diffuse Indirect", "Glossy Indirect")}
    assert parts["ViewLayer.Diffuse Indirect"].max() > 0.05
    helped = lantern("render", "--passes", "help")
    assert helped.returncode == 0
    for line in ("diffuse_indirect", "Diffuse Indirect.R/G/B", "glossy_indirect",
                 "Glossy Indirect.R/G/B"):
        assert line in helped.stdout, line
