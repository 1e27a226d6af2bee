"""Materials as node networks (docs/materials.md): the export of Blender's nodes as a
MaterialX-style network, its reading, the generated GLSL and its program sharing, and
each node family against its Cycles reference (references/patterns/, made by
references/make_pattern_references.py from tests/pattern_scenes.py).

The FLIP is measured on the quads' interiors (2 pixels in from every tile edge): the
network is under test, not edge anti-aliasing (docs/rendering.md measures that)."""
import functools
import pathlib

import numpy as np
import pytest

import pattern_scenes
from image_metrics import flip_map

PATTERNS = pathlib.Path(__file__).resolve().parent / "references" / "patterns"
FLIP_BOUND = 0.05


@functools.lru_cache(maxsize=None)
def exported(name):
    """(stage, export warnings) of a pattern scene, once per test session."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    pattern_scenes.SCENES[name]()
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    return stage, tuple(report.warnings)


def tile_interiors(name):
    """Mask of pixels at least 2 px inside a quad of the scene's grid."""
    w, h = pattern_scenes.SIZE
    cols = pattern_scenes.COLUMNS
    stage, _ = exported(name)
    tiles = len([p for p in stage.Traverse() if p.GetTypeName() == "Mesh"])
    rows = (tiles + cols - 1) // cols
    extent = max(cols, rows)
    px = w / extent
    y0 = (extent - rows) / 2.0 * px
    mask = np.zeros((h, w), bool)
    for i in range(tiles):
        x, y = i % cols, i // cols
        top, left = int(np.ceil(y0 + y * px)) + 2, int(np.ceil(x * px)) + 2
        bottom, right = int(y0 + (y + 1) * px) - 2, int((x + 1) * px) - 2
        mask[top:bottom, left:right] = True
    return mask


def lantern_flip(name):
    from lantern.engine import RenderSettings, read_exr, render_stage
    stage, _ = exported(name)
    w, h = pattern_scenes.SIZE
    result = render_stage(stage, RenderSettings(width=w, height=h))
    reference = read_exr(str(PATTERNS / f"{name}.exr"))
    errors = flip_map(result.rgba, reference)
    return float(errors[tile_interiors(name)].mean()), result


@pytest.mark.parametrize("name", sorted(pattern_scenes.SCENES))
def test_node_family_within_flip_of_cycles(name):
    _, warnings = exported(name)
    assert warnings == (), warnings
    flip, result = lantern_flip(name)
    print(f"{name}: interior HDR-FLIP {flip:.4f}")
    assert not result.warnings, result.warnings
    assert flip < FLIP_BOUND


def test_network_is_written_on_the_mtlx_context_with_preview_fallback():
    from pxr import UsdShade
    stage, _ = exported("color")
    mat = UsdShade.Material(stage.GetPrimAtPath("/root/_materials/color_invert"))
    preview = mat.ComputeSurfaceSource()[0]
    assert preview.GetIdAttr().Get() == "UsdPreviewSurface"
    out = mat.GetSurfaceOutput("mtlx")
    mtlx = UsdShade.Shader(out.GetValueProducingAttributes()[0].GetPrim())
    assert mtlx.GetIdAttr().Get() == "ND_UsdPreviewSurface_surfaceshader"
    ids = {UsdShade.Shader(p).GetIdAttr().Get() for p in
           stage.GetPrimAtPath("/root/_materials/color_invert/Pattern").GetChildren()}
    assert {"ND_lantern_invert", "ND_lantern_combine_color", "ND_lantern_uv"} <= ids


def test_equal_shapes_share_one_program_and_differ_in_parameters():
    """mix_<blend> materials differ only in the blend type (shape); two materials with
    the same shape but other values generate one source."""
    from lantern.engine.gpu.pattern import code_of, parameters
    from lantern.engine.scene import PatternGraph, PatternNode
    node = lambda v: PatternNode("n0_rgb", "rgb", (), (("color", "color", v),), ())  # noqa: E731
    a = PatternGraph((node((0.1, 0.2, 0.3)),), (("diffuseColor", "n0_rgb", "color", "color"),))
    b = PatternGraph((node((0.9, 0.8, 0.7)),), (("diffuseColor", "n0_rgb", "color", "color"),))
    assert code_of(a) is code_of(b)
    assert parameters(a)[0, :3].tolist() == pytest.approx([0.1, 0.2, 0.3])
    assert parameters(b)[0, :3].tolist() == pytest.approx([0.9, 0.8, 0.7])


def test_unsupported_node_upstream_is_one_warning_and_the_fallback(empty_scene):
    import bpy
    from lantern.exporters import stage_from_depsgraph
    mat, tree, bsdf = pattern_scenes._principled("Brick")
    brick = tree.nodes.new("ShaderNodeTexBrick")
    brick.name = "My Brick"
    inv = tree.nodes.new("ShaderNodeInvert")
    tree.links.new(brick.outputs["Color"], inv.inputs["Color"])
    tree.links.new(inv.outputs[0], bsdf.inputs["Base Color"])
    bsdf.inputs["Base Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    me = bpy.data.meshes.new("q")
    me.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [], [(0, 1, 2)])
    me.materials.append(mat)
    ob = bpy.data.objects.new("q", me)
    bpy.context.scene.collection.objects.link(ob)
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    named = [w for w in report.warnings if "My Brick" in w]
    assert len(named) == 1 and "Brick" in named[0], report.warnings
    assert not stage.GetPrimAtPath("/root/_materials/Brick/Pattern")


def test_materials_without_networks_load_no_generator_and_keep_the_fast_path():
    from lantern.engine.gpu.pattern import material_variant
    from lantern.engine.scene import Material
    assert material_variant(Material(name="plain")) == ()
