"""Materials as node networks (docs/materials.md): the export of Blender's nodes as a
MaterialX-style network, its reading, the generated GLSL and its program sharing, and
each node family against its Cycles reference (references/patterns/, made by
references/make_pattern_references.py from tests/pattern_scenes.py).

The FLIP is measured on the quads' interiors (2 pixels in from every tile edge), each
on its own: the network is under test, not the quads' edge anti-aliasing
(docs/rendering.md measures that)."""
import functools
import pathlib

import numpy as np
import pytest

import pattern_scenes
from image_metrics import mean_flip

PATTERNS = pathlib.Path(__file__).resolve().parent / "references" / "patterns"
FLIP_BOUND = 0.05


@functools.lru_cache(maxsize=None)
def exported(name):
    """(stage, export warnings) of a pattern scene, once per test session; the stage
    passes pxr's validators."""
    import bpy
    from lantern.exporters import stage_from_depsgraph, validation_errors
    pattern_scenes.SCENES[name]()
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert validation_errors(stage) == []
    return stage, tuple(report.warnings)


def tiles(name):
    """{material name: (rows, columns) slices} of the quads' interiors, 2 pixels in
    from every tile edge."""
    import bpy
    w, h = pattern_scenes.SIZE
    pattern_scenes.SCENES[name]()
    quads = sorted((ob for ob in bpy.data.objects if ob.type == "MESH"),
                   key=lambda ob: (-ob.data.vertices[3].co.y, ob.data.vertices[0].co.x))
    cols = pattern_scenes.COLUMNS
    rows = (len(quads) + cols - 1) // cols
    extent = max(cols, rows)
    px = w / extent
    y0 = (extent - rows) / 2.0 * px
    out = {}
    for i, ob in enumerate(quads):
        x, y = i % cols, i // cols
        top, left = int(np.ceil(y0 + y * px)) + 2, int(np.ceil(x * px)) + 2
        bottom, right = int(y0 + (y + 1) * px) - 2, int((x + 1) * px) - 2
        out[ob.data.materials[0].name] = (slice(top, bottom), slice(left, right))
    return out


def lantern_flip(name, preset="ultra"):
    """(mean over tiles of each tile interior's HDR-FLIP, {material: FLIP}, result):
    each interior is compared on its own, so that FLIP's spatial filter does not carry
    the tile edges' anti-aliasing into it. The ultra preset's 3x3 supersampling stands
    in for Cycles' 1.5 px pixel filter on the patterns' own edges (checker cells, ramp
    steps); docs/materials.md gives the medium preset's figures too."""
    from lantern.engine import RenderSettings, read_exr, render_stage
    from lantern.engine.bounces import DIRECT
    stage, _ = exported(name)
    w, h = pattern_scenes.SIZE
    # The references are Cycles' with bounces 0 (make_cycles_references.configure_cycles).
    result = render_stage(stage, RenderSettings(width=w, height=h, preset=preset, bounces=DIRECT))
    reference = read_exr(str(PATTERNS / f"{name}.exr"))
    per_tile = {mat: mean_flip(result.rgba[t], reference[t]) for mat, t in tiles(name).items()}
    return float(np.mean(list(per_tile.values()))), per_tile, result


@pytest.mark.parametrize("name", sorted(pattern_scenes.SCENES))
def test_node_family_within_flip_of_cycles(name):
    _, warnings = exported(name)
    assert warnings == (), warnings
    flip, per_tile, result = lantern_flip(name)
    worst = max(per_tile, key=per_tile.get)
    print(f"{name}: interior HDR-FLIP {flip:.4f}, worst {worst} {per_tile[worst]:.4f}")
    # An emission fed by a network lights only itself, and says so (engine/emitters.py);
    # each tile is measured on its own surface.
    said = [w for w in result.warnings if "comes from a node network" not in w]
    assert not said, said
    assert flip < FLIP_BOUND


def test_checker_cells_are_averaged_as_cycles_pixel_filter_at_medium():
    """A preset without supersampling (medium: one sample a pixel) draws the checker's
    cells as Cycles' pixel filter averages them (shaders/pattern_lib.glsl pt_checker):
    the mapping scene's six checker quads at medium, their mean within the pattern
    bound (0.025; 0.146 when one sample a pixel read the 0/1 cells, each quad 0.07 to
    0.18; the Normal mapping's quad is the worst, 0.063)."""
    _, per_tile, _ = lantern_flip("mapping", preset="medium")
    checkers = {mat: f for mat, f in per_tile.items() if "checker" in mat}
    assert len(checkers) == 6
    assert np.mean(list(checkers.values())) < FLIP_BOUND, checkers


def test_network_is_written_on_the_mtlx_context_with_preview_fallback():
    from pxr import UsdShade
    stage, _ = exported("color")
    mat = UsdShade.Material(stage.GetPrimAtPath("/root/_materials/color_invert"))
    preview = mat.ComputeSurfaceSource()[0]
    assert preview.GetIdAttr().Get() == "UsdPreviewSurface"
    out = mat.GetSurfaceOutput("mtlx")
    mtlx = UsdShade.Shader(out.GetValueProducingAttributes()[0].GetPrim())
    assert mtlx.GetIdAttr().Get() == "ND_UsdPreviewSurface_surfaceshader"
    ids = {p.GetAttribute("lantern:nodeDef").Get() for p in
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


def _one_quad_stage(build):
    """A stage of one pattern quad (pattern_scenes' lighting), exported afresh."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    pattern_scenes._grid("live", [("quad", build)])
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert not report.warnings, report.warnings
    return stage


def made(result):
    """Programs a render compiled or loaded from the persistent program cache."""
    return result.stats["programs_compiled"] + result.stats["programs_loaded"]


def _pattern_node(stage, kind):
    from pxr import UsdShade
    graph = stage.GetPrimAtPath("/root/_materials/live_quad/Pattern")
    return next(UsdShade.Shader(p) for p in graph.GetChildren()
                if p.GetAttribute("lantern:nodeDef").Get() == f"ND_lantern_{kind}")


def test_a_value_edit_uploads_parameters_and_compiles_nothing():
    from lantern.engine import RenderSettings, Session
    stage = _one_quad_stage(pattern_scenes._invert)
    with Session(stage, RenderSettings(width=32, height=32)) as session:
        session.render()
        before = session.render()
        assert made(before) == 0
        _pattern_node(stage, "invert").GetInput("fac").Set(0.1)
        after = session.render()
    assert made(after) == 0
    assert 0 < after.stats["pattern_bytes"] <= 1024
    assert np.abs(after.rgba[16, 3, :3] - before.rgba[16, 3, :3]).max() > 0.1


def test_a_half_metal_of_roughness_1_matches_cycles():
    """The mix_shader scene's metal quad (a Mix Shader of metallic 0 and 1, as Cycles'
    Principled BSDF blends its lobes): each lobe has its own multiple-scattering
    energy, tinted by Kulla and Conty's Fms as Cycles' (0.065 with one factor for the
    blended F0 and F0 in Fms' place, 0.0156 with the table read half a texel short;
    0.0037 now)."""
    _, per_tile, _ = lantern_flip("mix_shader")
    print(f"half metal, roughness 1: HDR-FLIP {per_tile['mix_shader_metal']:.4f}")
    assert per_tile["mix_shader_metal"] < 0.01


def test_a_skinned_mesh_draws_its_colour_attribute():
    """A skinned quad (one bone, at rest) reads its colour attribute as the static one
    does: the colours ride beside the deformed vertices (engine/gpu/stores.py)."""
    import bpy
    from _export_helpers import add_armature_modifier, make_armature
    from lantern.engine import RenderSettings, read_exr, render_stage
    from lantern.exporters import stage_from_depsgraph
    pattern_scenes.SCENES["attribute"]()
    quad = bpy.data.objects["attribute_render"]
    arm = make_armature(bone_names=("Root",))
    group = quad.vertex_groups.new(name="Root")
    group.add([v.index for v in quad.data.vertices], 1.0, "REPLACE")
    add_armature_modifier(quad, arm)
    bpy.context.view_layer.update()
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert report.warnings == [], report.warnings
    w, h = pattern_scenes.SIZE
    from lantern.engine.bounces import DIRECT
    result = render_stage(stage, RenderSettings(width=w, height=h, preset="ultra",
                                                bounces=DIRECT))      # as the reference
    assert result.stats["meshes_skinned"] == 1
    t = tiles("attribute")["attribute_render"]
    reference = read_exr(str(PATTERNS / "attribute.exr"))
    flip = mean_flip(result.rgba[t], reference[t])
    print(f"skinned quad's colour attribute: HDR-FLIP {flip:.4f}")
    assert flip < 0.01


def test_a_material_edit_keeps_a_networks_images_on_the_gpu():
    """A network's image stays uploaded across a material edit: the edit's render
    uploads no texture (the images of networks once went with every material edit and
    came back as new uploads)."""
    from lantern.engine import RenderSettings, Session
    stage = _one_quad_stage(pattern_scenes._image_multiplied)
    with Session(stage, RenderSettings(width=32, height=32)) as session:
        first = session.render()
        assert first.stats["bytes_by_kind"].get("textures", 0) > 0
        _pattern_node(stage, "mix").GetInput("factor").Set(0.5)
        after = session.render()
    assert after.stats["bytes_by_kind"].get("textures", 0) == 0, after.stats["bytes_by_kind"]


def test_a_graph_shape_edit_compiles_one_variant():
    from lantern.engine import RenderSettings, Session
    stage = _one_quad_stage(pattern_scenes._mix_blend("MULTIPLY"))
    with Session(stage, RenderSettings(width=32, height=32)) as session:
        session.render()
        before = session.render()
        # A shape no other test draws (the process's program cache is shared).
        mix = _pattern_node(stage, "mix")
        mix.GetInput("blend_type").Set("LINEAR_LIGHT")
        mix.GetInput("clamp_result").Set("1")
        after = session.render()
    assert made(after) == 1
    assert np.abs(after.rgba[16, 3, :3] - before.rgba[16, 3, :3]).max() > 0.05


def test_a_network_of_eight_images_reads_each_from_its_own_unit(tmp_path):
    """core/pattern_nodes.MAX_IMAGES images in one network (Vector Math Add of eight
    solid raw images): the sum is exact, so no image reads another's texture unit
    (images 5-8 share units with the overlays and the environment's prefilter)."""
    import bpy
    from lantern.core.pattern_nodes import MAX_IMAGES
    from lantern.engine import RenderSettings, render_stage
    from reference_scenes import _write_image
    colours = [np.array([(k + 1) * 10, (MAX_IMAGES - k) * 9, (k % 3) * 20 + 5]) for k in
               range(MAX_IMAGES)]

    def build(tree, bsdf):
        total = None
        for k, colour in enumerate(colours):
            path = str(tmp_path / f"solid{k}.png")
            _write_image(path, np.concatenate([np.broadcast_to(colour, (4, 4, 3)),
                                               np.full((4, 4, 1), 255)], -1).astype(np.uint8))
            node = tree.nodes.new("ShaderNodeTexImage")
            node.image = bpy.data.images.load(path)
            node.image.colorspace_settings.name = "Non-Color"
            if total is None:
                total = node.outputs["Color"]
                continue
            add = tree.nodes.new("ShaderNodeVectorMath")
            add.operation = "ADD"
            tree.links.new(total, add.inputs[0])
            tree.links.new(node.outputs["Color"], add.inputs[1])
            total = add.outputs[0]
        tree.links.new(total, bsdf.inputs["Base Color"])
    stage = _one_quad_stage(build)
    rgba = render_stage(stage, RenderSettings(width=32, height=32)).rgba
    want = np.sum(colours, axis=0) / 255.0
    assert np.allclose(rgba[16, 3, :3], want, atol=3e-3), (rgba[16, 3, :3], want)


def _shape_edit_renders(blend, background=True):
    """(before the edit, the edit's first frame, the frame after its program is made, the
    session's stats along the way) of a Mix blend-type edit in one Session."""
    from lantern.engine import RenderSettings, Session
    stage = _one_quad_stage(pattern_scenes._mix_blend("MULTIPLY"))
    settings = RenderSettings(width=32, height=32, background_compile=background)
    with Session(stage, settings) as session:
        session.render()
        before = session.render()
        mix = _pattern_node(stage, "mix")
        mix.GetInput("blend_type").Set(blend)   # clamped: a shape no other test draws
        mix.GetInput("clamp_result").Set("1")
        edited = session.render()
        pending = session.programs_pending()
        assert session.wait_programs(timeout=120)
        after = session.render()
    with Session(stage, RenderSettings(width=32, height=32)) as fresh:
        expected = fresh.render()
    return before, edited, after, expected, pending


def test_a_viewports_graph_edit_is_compiled_off_the_render_thread():
    """With background_compile (the viewport's), a graph-shape edit's frame draws the
    old variant and compiles nothing; a helper process makes the new program and
    stores its binary, and the next frame loads it and draws the edit, as a session
    without the helper draws it."""
    before, edited, after, expected, pending = _shape_edit_renders("DIFFERENCE")
    assert edited.stats["programs_pending"] == 1 and pending in (0, 1)
    assert edited.stats["programs_compiled"] == 0
    assert np.array_equal(edited.rgba, before.rgba)          # the old variant, as it was
    assert after.stats["programs_pending"] == 0
    assert after.stats["programs_compiled"] == 0 and after.stats["programs_loaded"] == 1
    assert np.array_equal(after.rgba, expected.rgba)
    assert np.abs(after.rgba[16, 3, :3] - before.rgba[16, 3, :3]).max() > 0.05


def test_without_program_binaries_a_graph_edit_compiles_in_place(monkeypatch):
    """No persistent program cache (LANTERN_NO_PROGRAM_CACHE=1): nothing can be made
    elsewhere, so the edit's own frame compiles it and draws it."""
    monkeypatch.setenv("LANTERN_NO_PROGRAM_CACHE", "1")
    before, edited, after, expected, _ = _shape_edit_renders("EXCLUSION")
    assert edited.stats["programs_pending"] == 0 and edited.stats["programs_compiled"] == 1
    assert np.array_equal(edited.rgba, expected.rgba)


@pytest.mark.parametrize("edit, says", [
    (lambda node: node.GetPrim().GetAttribute("lantern:nodeDef").Set("ND_image_color3"),
     "is not supported"),
    (lambda node: node.GetInput("fac").Set(float("nan")), "is not finite"),
])
def test_a_bad_node_is_one_warning_and_the_preview_value(edit, says):
    """A network the engine cannot draw: the warning names the material and the node,
    and the input draws the UsdPreviewSurface constant (here the socket's colour)."""
    from lantern.engine import RenderSettings, render_stage
    stage = _one_quad_stage(pattern_scenes._invert)
    good = render_stage(stage, RenderSettings(width=32, height=32))
    edit(_pattern_node(stage, "invert"))
    bad = render_stage(stage, RenderSettings(width=32, height=32))
    named = [w for w in bad.warnings if "live_quad" in w and "invert" in w]
    assert len(named) == 1 and says in named[0], bad.warnings
    assert np.isfinite(bad.rgba).all()
    # Invert's fallback: its Color socket's default, lit as the base colour.
    assert np.abs(bad.rgba[16, 3, :3] - good.rgba[16, 3, :3]).max() > 0.01


def test_udim_tiles_are_written_by_their_token_copied_and_read_from_the_file(tmp_path):
    """The UDIM image straight on Base Color keeps its `<UDIM>` path; "copy" mode copies
    every tile beside the layer; the file renders as the in-memory stage does."""
    import os
    import bpy
    from pxr import Usd, UsdShade
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import validation_errors
    from lantern.exporters.api import ExportOptions, export_depsgraph_to_file
    memory, _ = exported("udim")
    pattern_scenes.build_udim()
    out = tmp_path / "udim.usda"
    report = export_depsgraph_to_file(bpy.context.evaluated_depsgraph_get(), str(out),
                                      ExportOptions(textures="copy", animation=False))
    assert not report.warnings, report.warnings
    stage = Usd.Stage.Open(str(out))
    assert validation_errors(stage) == []
    files = {UsdShade.Shader(p).GetInput("file").Get().path for p in stage.Traverse()
             if p.IsA(UsdShade.Shader) and UsdShade.Shader(p).GetIdAttr().Get() == "UsdUVTexture"}
    stem = f"lantern-udim-{os.getpid()}"
    assert files == {f"./udim_textures/{stem}.<UDIM>.png"}
    assert sorted(os.listdir(tmp_path / "udim_textures")) == [
        f"{stem}.{tile}.png" for tile in pattern_scenes.UDIM_TILES]
    settings = RenderSettings(width=64, height=64)
    from_file, in_memory = render_stage(stage, settings), render_stage(memory, settings)
    assert not from_file.warnings, from_file.warnings
    np.testing.assert_allclose(from_file.rgba, in_memory.rgba, atol=1e-6)


def test_the_materials_of_one_mesh_read_their_own_attributes(empty_scene):
    """Two quads of one mesh, each with a material whose Color Attribute node names
    another attribute of that mesh: each quad draws its own (the pattern scenes'
    light: the pixel is the base colour)."""
    import bpy
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import stage_from_depsgraph
    from reference_scenes import _camera, _mesh_object, _sun, _world
    scene = bpy.context.scene
    _world(scene, color=(0.0, 0.0, 0.0), strength=0.0)
    _sun(scene, 3.141592653589793)
    colours = {"Left": (0.7, 0.1, 0.1), "Right": (0.1, 0.2, 0.7)}
    materials = []
    for name in colours:
        mat, tree, bsdf = pattern_scenes._principled(name)
        node = tree.nodes.new("ShaderNodeVertexColor")
        node.layer_name = name
        tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
        materials.append(mat)
    ob = _mesh_object(scene, "Pair", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0),
                                      (2, 1, 0)], [(0, 1, 2, 3), (1, 4, 5, 2)], materials[0],
                      [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0), (1, 0), (1, 1), (0, 1)])
    ob.data.materials.append(materials[1])
    ob.data.polygons[1].material_index = 1
    for name, colour in colours.items():
        attribute = ob.data.color_attributes.new(name, "FLOAT_COLOR", "POINT")
        for item in attribute.data:
            item.color = (*colour, 1.0)
    _camera(scene, (1.0, 0.5, 10.0), (1.0, 0.5, 0.0), ortho_scale=2.0)
    bpy.context.view_layer.update()
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert report.warnings == [], report.warnings
    image = render_stage(stage, RenderSettings(width=64, height=32)).rgba
    np.testing.assert_allclose(image[16, 12, :3], colours["Left"], atol=0.02)
    np.testing.assert_allclose(image[16, 52, :3], colours["Right"], atol=0.02)


INTERPOLATION_SCENES = [f"image_{i.lower()}" for i in pattern_scenes.INTERPOLATIONS]


@pytest.mark.parametrize("name", INTERPOLATION_SCENES)
def test_an_image_interpolation_is_within_flip_of_cycles_at_medium(name):
    """Each Image Texture interpolation, straight on Base Color and in a network,
    magnified and minified, at the medium preset (its ultra figure is
    test_node_family_within_flip_of_cycles'): Cycles' Closest texels are sharp
    squares, its Cubic a B-spline, and Lantern's the same. Smart is Cubic where
    magnified and Linear where not (Cycles renders it as Cubic throughout)."""
    flip, per_tile, result = lantern_flip(name, preset="medium")
    worst = max(per_tile, key=per_tile.get)
    print(f"{name} (medium): interior HDR-FLIP {flip:.4f}, worst {worst} {per_tile[worst]:.4f}")
    assert not result.warnings, result.warnings
    assert flip < FLIP_BOUND


def _filtertypes(stage, material):
    """(lantern:filtertype of the material's UsdUVTextures, filtertype of its network's
    images): None where not authored."""
    from pxr import Usd, UsdShade
    textures, network = [], []
    for prim in Usd.PrimRange(stage.GetPrimAtPath(f"/root/_materials/{material}")):
        shader = UsdShade.Shader(prim)
        if shader and shader.GetIdAttr().Get() == "UsdUVTexture":
            attr = prim.GetAttribute("lantern:filtertype")
            textures.append(attr.Get() if attr.HasAuthoredValue() else None)
        if prim.GetAttribute("lantern:nodeDef").Get() == "ND_lantern_image":
            network.append(shader.GetInput("filtertype").Get())
    return textures, network


def test_the_interpolation_is_written_where_the_stage_can_say_it():
    """A UsdUVTexture has no input for it: lantern:filtertype, written where not
    Linear; a network's image has MaterialX's filtertype setting (and smart)."""
    stage, _ = exported("image_closest")
    assert _filtertypes(stage, "image_closest_magnified") == (["closest"], [])
    assert _filtertypes(stage, "image_closest_network_magnified") == ([], ["closest"])
    stage, _ = exported("image_smart")
    assert _filtertypes(stage, "image_smart_minified") == (["smart"], [])
    stage, _ = exported("image_linear")
    assert _filtertypes(stage, "image_linear_magnified") == ([None], [])
    assert _filtertypes(stage, "image_linear_network_minified") == ([], ["linear"])


@pytest.mark.parametrize("interpolation", pattern_scenes.INTERPOLATIONS)
def test_a_networks_image_draws_as_the_image_straight_on_the_input(interpolation):
    """One lookup for both (material.glsl sample_map: the Map's filtertype, the
    program's FILTER_ defines from every image it binds): the image in a network,
    behind a Mapping node that changes nothing, gives the pixels the same image gives
    straight on Base Color, magnified 8 times and minified 1.5 times (64 x 64 medium:
    each quad 32 pixels)."""
    import bpy
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import stage_from_depsgraph
    name, kind = f"paths_{interpolation.lower()}", interpolation.lower()
    pattern_scenes.build_interpolation_paths(interpolation)()
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert not report.warnings, report.warnings
    assert _filtertypes(stage, f"{name}_straight_magnified") == \
        ([None if kind == "linear" else kind], [])
    assert _filtertypes(stage, f"{name}_network_magnified") == ([], [kind])
    result = render_stage(stage, RenderSettings(width=64, height=64, preset="medium"))
    assert not result.warnings, result.warnings
    for scale, rows in (("magnified", slice(2, 30)), ("minified", slice(34, 62))):
        straight, network = result.rgba[rows, 2:30, :3], result.rgba[rows, 34:62, :3]
        worst = float(np.abs(network - straight).max())
        print(f"{interpolation} {scale}: network against straight, max |difference| "
              f"{worst:.2e} (the image's own contrast {np.ptp(straight):.2f})")
        assert worst <= 2e-3, (interpolation, scale)


def test_an_unknown_interpolation_warns_and_reads_as_linear():
    """A filter type the engine does not know, on a UsdUVTexture and on a network's
    image: one warning each naming the prim and the value, and the image drawn as
    Linear draws it."""
    import bpy
    from pxr import Usd, UsdShade
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import stage_from_depsgraph

    def stage_of(interpolation):
        pattern_scenes.SCENES[f"image_{interpolation}"]()
        return stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())[0]

    stage = stage_of("closest")
    edited = []
    for prim in Usd.PrimRange(stage.GetPrimAtPath("/root/_materials")):
        attr = prim.GetAttribute("lantern:filtertype")
        if attr.HasAuthoredValue():
            attr.Set("bicubic")
            edited.append(str(prim.GetPath()))
        elif prim.GetAttribute("lantern:nodeDef").Get() == "ND_lantern_image":
            UsdShade.Shader(prim).GetInput("filtertype").Set("bicubic")
            edited.append(str(prim.GetPath()))
    assert len(edited) == 4
    settings = RenderSettings(width=64, height=64)
    result = render_stage(stage, settings)
    for path in edited:
        named = [w for w in result.warnings if path in w]
        assert len(named) == 1 and "'bicubic'" in named[0] and "Linear" in named[0], result.warnings
    linear = render_stage(stage_of("linear"), settings)
    np.testing.assert_array_equal(result.rgba, linear.rgba)
