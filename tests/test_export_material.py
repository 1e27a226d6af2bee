"""Principled BSDF -> UsdPreviewSurface, textures, warnings; the world's dome."""
import math
import os

import bpy
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdShade

from _export_helpers import cube_object, export_current
from lantern.exporters.gather.material import normal_map_scale_bias, principled_ior


def principled_material(name):
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    return mat, tree, bsdf


def image_on_base_cube(name, image, obj="C"):
    """A cube whose material (`name`) has `image` on the Principled BSDF's Base Color."""
    mat, tree, bsdf = principled_material(name)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    cube_object(obj).data.materials.append(mat)
    return mat


def surface(stage, name):
    shader = UsdShade.Shader(stage.GetPrimAtPath(f"/root/_materials/{name}/PreviewSurface"))
    assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
    return shader


def source(shader, input_name):
    (src,), _ = shader.GetInput(input_name).GetConnectedSources()
    return UsdShade.Shader(src.source.GetPrim()), src.sourceName


def saved_image(tmp_path, name, colorspace):
    img = bpy.data.images.new(name, 4, 4)
    img.filepath_raw = str(tmp_path / f"{name}.png")
    img.file_format = "PNG"
    img.save()
    img.colorspace_settings.name = colorspace
    return img


def test_principled_values(empty_scene):
    mat, tree, bsdf = principled_material("Plain")
    bsdf.inputs["Base Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    bsdf.inputs["Metallic"].default_value = 0.7
    bsdf.inputs["Roughness"].default_value = 0.3
    bsdf.inputs["IOR"].default_value = 1.45
    bsdf.inputs["Specular IOR Level"].default_value = 0.5
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.5, 0.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 2.0
    bsdf.inputs["Alpha"].default_value = 0.8
    cube_object("C").data.materials.append(mat)
    stage, report = export_current()
    s = surface(stage, "Plain")
    assert tuple(s.GetInput("diffuseColor").Get()) == pytest.approx((0.2, 0.4, 0.6))
    assert s.GetInput("metallic").Get() == pytest.approx(0.7)
    assert s.GetInput("roughness").Get() == pytest.approx(0.3)
    assert s.GetInput("ior").Get() == pytest.approx(1.45, rel=1e-5)  # level 0.5 keeps IOR
    assert tuple(s.GetInput("emissiveColor").Get()) == pytest.approx((2.0, 1.0, 0.0))
    assert s.GetInput("opacity").Get() == pytest.approx(0.8)
    assert report.counts["materials"] == 1 and report.warnings == []


def test_specular_level_zero_gives_ior_one(empty_scene):
    mat, _, bsdf = principled_material("NoSpec")
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    cube_object("C").data.materials.append(mat)
    stage, _ = export_current()
    assert surface(stage, "NoSpec").GetInput("ior").Get() == pytest.approx(1.0)


def test_ior_mapping_keeps_f0():
    f0 = lambda n: ((n - 1) / (n + 1)) ** 2
    assert f0(principled_ior(1.5, 1.0)) == pytest.approx(2 * f0(1.5))
    assert principled_ior(1.5, 0.5) == pytest.approx(1.5)


def test_image_textures_wrap_and_colour_space(empty_scene, tmp_path):
    mat, tree, bsdf = principled_material("Textured")
    color = tree.nodes.new("ShaderNodeTexImage")
    color.image = saved_image(tmp_path, "albedo", "sRGB")
    color.extension = "EXTEND"
    orm = tree.nodes.new("ShaderNodeTexImage")
    orm.image = saved_image(tmp_path, "orm", "Non-Color")
    orm.extension = "MIRROR"
    uvmap = tree.nodes.new("ShaderNodeUVMap")
    uvmap.uv_map = "Second"
    tree.links.new(uvmap.outputs["UV"], orm.inputs["Vector"])
    sep = tree.nodes.new("ShaderNodeSeparateColor")
    tree.links.new(color.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(orm.outputs["Color"], sep.inputs["Color"])
    tree.links.new(sep.outputs["Blue"], bsdf.inputs["Metallic"])
    ob = cube_object("C")
    ob.data.uv_layers.new(name="UVMap")
    ob.data.uv_layers.new(name="Second")
    ob.data.materials.append(mat)
    stage, report = export_current(path=tmp_path / "scene.usda")
    s = surface(stage, "Textured")

    tex, out = source(s, "diffuseColor")
    assert tex.GetIdAttr().Get() == "UsdUVTexture" and out == "rgb"
    assert tex.GetInput("file").Get().path == "./albedo.png"
    assert tex.GetInput("wrapS").Get() == tex.GetInput("wrapT").Get() == "clamp"
    assert tex.GetInput("sourceColorSpace").Get() == "sRGB"
    reader, _ = source(tex, "st")
    assert reader.GetIdAttr().Get() == "UsdPrimvarReader_float2"
    assert reader.GetInput("varname").Get() == "UVMap"  # the render-active map

    tex, out = source(s, "metallic")
    assert out == "b"
    assert tex.GetInput("wrapS").Get() == "mirror"
    assert tex.GetInput("sourceColorSpace").Get() == "raw"
    reader, _ = source(tex, "st")
    assert reader.GetInput("varname").Get() == "Second"
    assert report.warnings == []


def test_normal_map_strength_one(empty_scene, tmp_path):
    mat, tree, bsdf = principled_material("Bumpy")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = saved_image(tmp_path, "normal", "Non-Color")
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    cube_object("C").data.materials.append(mat)
    stage, _ = export_current()
    shader, out = source(surface(stage, "Bumpy"), "normal")
    assert out == "rgb"
    assert tuple(shader.GetInput("scale").Get()) == (2, 2, 2, 1)
    assert tuple(shader.GetInput("bias").Get()) == (-1, -1, -1, 0)
    assert shader.GetInput("sourceColorSpace").Get() == "raw"


def test_bump_map_correction_is_written_only_when_off(empty_scene):
    """Cycles' Bump Map Correction is on by default, as the engine's: the stage says
    only where a material turns it off (lantern:bumpMapCorrection = false)."""
    on, _, _ = principled_material("On")
    off, _, _ = principled_material("Off")
    off.cycles.use_bump_map_correction = False
    cube_object("A").data.materials.append(on)
    cube_object("B").data.materials.append(off)
    stage, _ = export_current()
    attr = "lantern:bumpMapCorrection"
    assert not stage.GetPrimAtPath("/root/_materials/On").HasAttribute(attr)
    assert stage.GetPrimAtPath("/root/_materials/Off").GetAttribute(attr).Get() is False


def test_bump_network_feeds_the_normal_and_chained_bumps_link(empty_scene):
    """A Bump node on a network's height becomes the graph's `normal`; a Bump whose own
    Normal input another Bump feeds links to it (chained bumps), with no warning."""
    mat, tree, bsdf = principled_material("Chained")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    outer, inner = tree.nodes.new("ShaderNodeBump"), tree.nodes.new("ShaderNodeBump")
    for bump in (outer, inner):
        tree.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    tree.links.new(inner.outputs["Normal"], outer.inputs["Normal"])
    tree.links.new(outer.outputs["Normal"], bsdf.inputs["Normal"])
    cube_object("A").data.materials.append(mat)
    stage, report = export_current()
    mtlx = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/Chained/MtlxSurface"))
    (src,), _ = mtlx.GetInput("normal").GetConnectedSources()
    graph_out = src.source.GetOutput(src.sourceName)
    (node,), _ = graph_out.GetConnectedSources()
    outer_node = UsdShade.Shader(node.source.GetPrim())
    assert outer_node.GetPrim().GetAttribute("lantern:nodeDef").Get() == "ND_lantern_bump"
    (inner_src,), _ = outer_node.GetInput("normal").GetConnectedSources()
    assert inner_src.source.GetPrim().GetAttribute("lantern:nodeDef").Get() == "ND_lantern_bump"
    assert report.warnings == []


def test_transparent_bsdf_in_a_mix_shader_is_the_opacity(empty_scene):
    """Mix Shader (factor f) of a Transparent BSDF and a Principled BSDF: the Principled
    BSDF's share is the opacity (f in the second slot, 1 - f in the first), times its own
    Alpha; a tinted Transparent BSDF is one warning (exported white)."""
    def mixed(name, slot, alpha=1.0, tint=(1.0, 1.0, 1.0, 1.0)):
        mat, tree, bsdf = principled_material(name)
        bsdf.inputs["Alpha"].default_value = alpha
        output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        mix = tree.nodes.new("ShaderNodeMixShader")
        mix.inputs[0].default_value = 0.3
        transparent = tree.nodes.new("ShaderNodeBsdfTransparent")
        transparent.inputs["Color"].default_value = tint
        shaders = [transparent.outputs[0], bsdf.outputs["BSDF"]][::1 if slot == 0 else -1]
        tree.links.new(shaders[0], mix.inputs[1])
        tree.links.new(shaders[1], mix.inputs[2])
        tree.links.new(mix.outputs[0], output.inputs["Surface"])
        return mat
    for obj, mat in (("A", mixed("First", 0)), ("B", mixed("Second", 1)),
                     ("C", mixed("Alpha", 0, alpha=0.5)),
                     ("D", mixed("Tinted", 0, tint=(1.0, 0.2, 0.2, 1.0)))):
        cube_object(obj).data.materials.append(mat)
    stage, report = export_current()
    opacity = {name: surface(stage, name).GetInput("opacity").Get()
               for name in ("First", "Second", "Alpha", "Tinted")}
    assert opacity == pytest.approx({"First": 0.3, "Second": 0.7, "Alpha": 0.15, "Tinted": 0.3})
    assert [w for w in report.warnings if "Transparent BSDF" in w] == [
        w for w in report.warnings if "'Tinted'" in w] and len(report.warnings) == 1, \
        report.warnings


def _tiled_image(tmp_path, tiles=(1001, 1002)):
    from reference_scenes import _write_image
    for tile in tiles:
        _write_image(str(tmp_path / f"tiles.{tile}.png"), np.full((4, 4, 4), 200, np.uint8))
    img = bpy.data.images.load(str(tmp_path / "tiles.1001.png"))
    img.name = "Tiles"
    img.source = "TILED"                     # Blender finds the other tiles beside it
    return img


def test_a_udim_image_keeps_its_token_and_names_a_tile_without_a_file(empty_scene, tmp_path):
    """Straight on an input, a UDIM image is written as USD's `<UDIM>` path; a tile
    Blender lists but whose file is missing is one warning naming it."""
    img = _tiled_image(tmp_path)
    img.tiles.new(1003)                      # listed, never saved
    image_on_base_cube("Tiled", img)
    stage, report = export_current()
    shader, _ = source(surface(stage, "Tiled"), "diffuseColor")
    assert os.path.basename(shader.GetInput("file").Get().path) == "tiles.<UDIM>.png"
    assert len(report.warnings) == 1 and "'Tiles'" in report.warnings[0] and \
        "1003" in report.warnings[0], report.warnings


def test_a_udim_image_in_a_network_is_its_first_tile_with_one_warning(empty_scene, tmp_path):
    """A network samples one image a node: the first tile's file, and a warning naming
    the image and its tile count (not "not found")."""
    img = _tiled_image(tmp_path)
    mat, tree, bsdf = principled_material("Networked")
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = img
    invert = tree.nodes.new("ShaderNodeInvert")
    tree.links.new(node.outputs["Color"], invert.inputs["Color"])
    tree.links.new(invert.outputs["Color"], bsdf.inputs["Base Color"])
    cube_object("Cube").data.materials.append(mat)
    stage, report = export_current()
    files = [p.GetAttribute("inputs:file").Get().path for p in stage.Traverse()
             if p.GetAttribute("inputs:file")]
    assert [os.path.basename(f) for f in files] == ["tiles.1001.png"], files
    assert len(report.warnings) == 1 and "'Tiles'" in report.warnings[0] and \
        "2 tiles" in report.warnings[0] and "not found" not in report.warnings[0], report.warnings


def _group(name, inputs, outputs):
    """A shader node group with `inputs` and `outputs` [(name, socket type)]; returns
    (group tree, its Group Input node, its Group Output node)."""
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for sockets, in_out in ((inputs, "INPUT"), (outputs, "OUTPUT")):
        for socket_name, kind in sockets:
            group.interface.new_socket(name=socket_name, in_out=in_out, socket_type=kind)
    return group, group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")


def test_node_groups_are_read_through_as_cycles_compiles_them(empty_scene, tmp_path):
    """A Principled BSDF inside a group (inside another group): its Base Color comes
    through the Group Input from an image outside, and its unlinked Roughness input
    takes the group node's value."""
    shading, inner_in, inner_out = _group("Shading", [("Colour", "NodeSocketColor"),
                                                      ("Rough", "NodeSocketFloat")],
                                          [("BSDF", "NodeSocketShader")])
    bsdf = shading.nodes.new("ShaderNodeBsdfPrincipled")
    shading.links.new(inner_in.outputs["Colour"], bsdf.inputs["Base Color"])
    shading.links.new(inner_in.outputs["Rough"], bsdf.inputs["Roughness"])
    shading.links.new(bsdf.outputs["BSDF"], inner_out.inputs["BSDF"])
    wrapper, outer_in, outer_out = _group("Wrapper", [("Colour", "NodeSocketColor")],
                                          [("BSDF", "NodeSocketShader")])
    nested = wrapper.nodes.new("ShaderNodeGroup")
    nested.node_tree = shading
    nested.inputs["Rough"].default_value = 0.3
    wrapper.links.new(outer_in.outputs["Colour"], nested.inputs["Colour"])
    wrapper.links.new(nested.outputs["BSDF"], outer_out.inputs["BSDF"])
    mat = bpy.data.materials.new("Grouped")
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    group = tree.nodes.new("ShaderNodeGroup")
    group.node_tree = wrapper
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = saved_image(tmp_path, "grouped", "sRGB")
    tree.links.new(tex.outputs["Color"], group.inputs["Colour"])
    tree.links.new(group.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    cube_object("Cube").data.materials.append(mat)
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    shader = surface(stage, "Grouped")
    texture, _ = source(shader, "diffuseColor")
    assert texture.GetIdAttr().Get() == "UsdUVTexture"
    assert shader.GetInput("roughness").Get() == pytest.approx(0.3)


def test_a_group_used_twice_reads_each_instances_inputs(empty_scene):
    """One group (x * 2, a Math node inside) used twice in a network, with 0.1 and 0.3:
    two Math nodes in the pattern graph, each with its own value, named by its group."""
    double, group_in, group_out = _group("Double", [("x", "NodeSocketFloat")],
                                         [("y", "NodeSocketFloat")])
    times = double.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = 2.0
    double.links.new(group_in.outputs["x"], times.inputs[0])
    double.links.new(times.outputs[0], group_out.inputs["y"])
    mat, tree, bsdf = principled_material("Twice")
    add = tree.nodes.new("ShaderNodeMath")
    for k, value in enumerate((0.1, 0.3)):
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = double
        node.name = f"Double{k}"
        node.inputs["x"].default_value = value
        tree.links.new(node.outputs["y"], add.inputs[k])
    tree.links.new(add.outputs[0], bsdf.inputs["Roughness"])
    cube_object("Cube").data.materials.append(mat)
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    pattern = stage.GetPrimAtPath("/root/_materials/Twice/Pattern")
    values = sorted(round(p.GetAttribute("inputs:a").Get(), 6) for p in pattern.GetChildren()
                    if p.GetAttribute("lantern:nodeDef").Get() == "ND_lantern_math"
                    and p.GetAttribute("inputs:b").Get() == 2.0)
    assert values == [0.1, 0.3]


def test_colour_attributes_are_written_as_the_primvars_networks_read(empty_scene):
    """The render colour attribute becomes primvars:displayColor, a named one its own
    (a valid identifier), both faceVarying colour, scene linear; a name the mesh lacks
    is one warning naming the object."""
    ob = cube_object("Painted")
    col = ob.data.color_attributes.new("Col", "BYTE_COLOR", "CORNER")
    col.data[0].color = (0.5, 0.25, 1.0, 1.0)
    paint = ob.data.color_attributes.new("Wet Paint", "FLOAT_COLOR", "POINT")
    paint.data[0].color = (2.0, 0.5, 0.0, 1.0)
    ob.data.color_attributes.render_color_index = ob.data.color_attributes.find("Col")
    mat, tree, bsdf = principled_material("Reads")
    render, named, missing = (tree.nodes.new("ShaderNodeVertexColor") for _ in range(3))
    named.layer_name, missing.layer_name = "Wet Paint", "Nowhere"
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    tree.links.new(render.outputs["Color"], mix.inputs[6])
    tree.links.new(named.outputs["Color"], mix.inputs[7])
    tree.links.new(missing.outputs["Color"], bsdf.inputs["Emission Color"])
    tree.links.new(mix.outputs[2], bsdf.inputs["Base Color"])
    ob.data.materials.append(mat)
    stage, report = export_current()
    mesh = next(p for p in stage.Traverse() if p.GetTypeName() == "Mesh")
    primvars = UsdGeom.PrimvarsAPI(mesh)
    for name, first in (("displayColor", (0.5, 0.25, 1.0)), ("Wet_Paint", (2.0, 0.5, 0.0))):
        pv = primvars.GetPrimvar(name)
        assert pv.GetInterpolation() == "faceVarying"
        assert str(pv.GetTypeName()) == "color3f[]"
        values = np.asarray(pv.Get())
        assert len(values) == 24                  # the cube's corners
        if name == "Wet_Paint":                   # per point: the corners of point 0
            corners = np.asarray(UsdGeom.Mesh(mesh).GetFaceVertexIndicesAttr().Get()) == 0
            assert np.allclose(values[corners], first)
        else:
            assert np.allclose(values[0], first, atol=5e-3)    # 8-bit sRGB, read as linear
    assert [w for w in report.warnings if "Nowhere" in w and "Painted" in w], report.warnings


def test_a_colour_attributes_alpha_is_written_only_where_a_network_needs_it(empty_scene):
    """The render colour attribute with an alpha below 1 gets displayOpacity beside its
    displayColor; a named one that is opaque gets no opacity primvar."""
    ob = cube_object("Translucent")
    col = ob.data.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    col.data[0].color = (0.5, 0.25, 1.0, 0.4)
    ob.data.color_attributes.new("Opaque", "FLOAT_COLOR", "POINT")
    ob.data.color_attributes.render_color_index = ob.data.color_attributes.find("Col")
    mat, tree, bsdf = principled_material("ReadsAlpha")
    render, named = (tree.nodes.new("ShaderNodeVertexColor") for _ in range(2))
    named.layer_name = "Opaque"
    tree.links.new(render.outputs["Alpha"], bsdf.inputs["Alpha"])
    tree.links.new(named.outputs["Alpha"], bsdf.inputs["Roughness"])
    ob.data.materials.append(mat)
    stage, report = export_current()
    assert all("reads attributes" in w for w in report.warnings), report.warnings  # two
    mesh = next(p for p in stage.Traverse() if p.GetTypeName() == "Mesh")
    primvars = UsdGeom.PrimvarsAPI(mesh)
    opacity = primvars.GetPrimvar("displayOpacity")
    assert opacity.GetInterpolation() == "faceVarying"
    assert np.asarray(opacity.Get())[0] == pytest.approx(0.4)
    assert not primvars.GetPrimvar("Opaque_opacity")


def test_attributes_of_other_types_are_written_as_cycles_reads_them(empty_scene):
    """An Attribute node reading a 2D vector per corner (a UV map), a float per face and
    a vector per point: the UV map's own primvar, (f, f, f) and xyz per corner."""
    ob = cube_object("Attributes")
    me = ob.data
    uv = me.attributes.new("_CustomUVMap", "FLOAT2", "CORNER")
    uv.data.foreach_set("vector", np.tile([0.25, 0.75], len(me.loops)).astype(np.float32))
    face = me.attributes.new("weight", "FLOAT", "FACE")
    face.data.foreach_set("value", np.arange(len(me.polygons), dtype=np.float32))
    point = me.attributes.new("offset", "FLOAT_VECTOR", "POINT")
    point.data.foreach_set("vector", np.tile([1.0, 2.0, 3.0], len(me.vertices)).astype(np.float32))
    mat, tree, bsdf = principled_material("ReadsAttributes")
    add = tree.nodes.new("ShaderNodeVectorMath")
    for k, name in enumerate(("_CustomUVMap", "weight")):
        node = tree.nodes.new("ShaderNodeAttribute")
        node.attribute_name = name
        tree.links.new(node.outputs["Vector"], add.inputs[k])
    offset = tree.nodes.new("ShaderNodeAttribute")
    offset.attribute_name = "offset"
    tree.links.new(add.outputs[0], bsdf.inputs["Base Color"])
    tree.links.new(offset.outputs["Color"], bsdf.inputs["Emission Color"])
    me.materials.append(mat)
    stage, report = export_current()
    assert all("reads attributes" in w for w in report.warnings), report.warnings  # three
    mesh = next(p for p in stage.Traverse() if p.GetTypeName() == "Mesh")
    primvars = UsdGeom.PrimvarsAPI(mesh)
    values = {name: np.asarray(primvars.GetPrimvar(name).Get())
              for name in ("_CustomUVMap", "weight", "offset")}
    assert all(len(v) == 24 for v in values.values())
    # A 2D vector per corner is a UV map: the network reads its own primvar as (u, v, 0).
    assert str(primvars.GetPrimvar("_CustomUVMap").GetTypeName()) == "texCoord2f[]"
    assert np.allclose(values["_CustomUVMap"], (0.25, 0.75))
    assert np.allclose(values["offset"], (1.0, 2.0, 3.0))
    counts = UsdGeom.Mesh(mesh).GetFaceVertexCountsAttr().Get()
    assert np.allclose(values["weight"][:, 0], np.repeat(np.arange(len(counts)), counts))
    assert np.allclose(values["weight"][:, 0], values["weight"][:, 2])


def test_a_mix_of_two_bsdfs_mixes_their_inputs(empty_scene):
    """Mix Shader of two Principled BSDFs: constants mix into constants by a constant
    factor; a linked factor makes a network Mix per differing input; emissions add,
    weighted; no warning when their specular is the same."""
    def mixed(name, factor_linked):
        mat, tree, first = principled_material(name)
        first.inputs["Base Color"].default_value = (1.0, 0.0, 0.0, 1.0)
        first.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        first.inputs["Emission Strength"].default_value = 2.0
        second = tree.nodes.new("ShaderNodeBsdfPrincipled")
        second.inputs["Base Color"].default_value = (0.0, 0.0, 1.0, 1.0)
        second.inputs["Metallic"].default_value = 1.0
        output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        mix = tree.nodes.new("ShaderNodeMixShader")
        mix.inputs[0].default_value = 0.25
        if factor_linked:
            tree.links.new(tree.nodes.new("ShaderNodeTexGradient").outputs["Fac"], mix.inputs[0])
        tree.links.new(first.outputs["BSDF"], mix.inputs[1])
        tree.links.new(second.outputs["BSDF"], mix.inputs[2])
        tree.links.new(mix.outputs[0], output.inputs["Surface"])
        return mat
    cube_object("A").data.materials.append(mixed("Constant", False))
    cube_object("B").data.materials.append(mixed("Network", True))
    stage, report = export_current()
    constant = surface(stage, "Constant")
    assert constant.GetInput("diffuseColor").Get() == pytest.approx((0.75, 0.0, 0.25))
    assert constant.GetInput("metallic").Get() == pytest.approx(0.25)
    assert constant.GetInput("emissiveColor").Get() == pytest.approx((1.5, 1.5, 1.5))
    mtlx = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/Network/MtlxSurface"))
    for name in ("diffuseColor", "metallic"):
        (src,), _ = mtlx.GetInput(name).GetConnectedSources()
        (node,), _ = src.source.GetOutput(src.sourceName).GetConnectedSources()
        assert node.source.GetPrim().GetAttribute("lantern:nodeDef").Get() == "ND_lantern_mix"
    assert [w for w in report.warnings if "Network" in w] == [
        w for w in report.warnings if "emission under a textured factor" in w], report.warnings


def test_unknown_node_warns_with_material_and_node(empty_scene):
    # Brick is outside the pattern nodes (docs/materials.md; Noise is inside now).
    mat, tree, bsdf = principled_material("Bricky")
    brick = tree.nodes.new("ShaderNodeTexBrick")
    brick.name = "My Brick"
    tree.links.new(brick.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Base Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    cube_object("C").data.materials.append(mat)
    stage, report = export_current()
    assert any("Bricky" in w and "My Brick" in w for w in report.warnings), report.warnings
    # The fallback is the socket's own constant.
    assert tuple(surface(stage, "Bricky").GetInput("diffuseColor").Get()) == \
        pytest.approx((0.1, 0.2, 0.3))


def test_missing_image_warns_and_falls_back(empty_scene, tmp_path):
    gone = bpy.data.images.new("gone", 2, 2)
    gone.source = "FILE"
    gone.filepath = str(tmp_path / "gone.png")
    image_on_base_cube("Lost", gone)
    stage, report = export_current()
    assert any("Lost" in w and "gone.png" in w for w in report.warnings), report.warnings
    assert not surface(stage, "Lost").GetInput("diffuseColor").HasConnectedSource()


def test_backface_culling_makes_single_sided(empty_scene):
    mat, _, _ = principled_material("Culled")
    mat.use_backface_culling = True
    cube_object("C").data.materials.append(mat)
    cube_object("D")
    stage, _ = export_current()
    assert stage.GetPrimAtPath("/root/C/C_mesh").GetAttribute("doubleSided").Get() is False
    assert stage.GetPrimAtPath("/root/D/D_mesh").GetAttribute("doubleSided").Get() is True


# --- normal-map strength ------------------------------------------------------------------

def test_normal_map_strength_is_cycles_tangent_space_weighting():
    """n = 2c - 1 weighted as Cycles' svm_node_normal_map (tangent space):
    (s n.x, s n.y, 1 + clamp(s, 0, 1) (n.z - 1))."""
    c = np.array([0.8, 0.3, 0.7, 1.0])
    n = 2 * c[:3] - 1
    for s in (0.0, 0.5, 1.0, 2.0, 3.5):
        scale, bias = normal_map_scale_bias(s)
        k = min(max(s, 0.0), 1.0)
        expected = (s * n[0], s * n[1], 1 + k * (n[2] - 1))
        assert tuple(np.array(scale)[:3] * c[:3] + np.array(bias)[:3]) == pytest.approx(expected)
        assert scale[3] == 1.0 and bias[3] == 0.0
    assert normal_map_scale_bias(1.0) == ((2, 2, 2, 1), (-1, -1, -1, 0))


def _normal_mapped_plane(name, colour, strength):
    """A 2x2 plane (UVs along x and y) whose normal map is a constant float colour."""
    image = bpy.data.images.new(name + "_n", 4, 4, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set(np.tile(np.array([*colour, 1.0], np.float32), 16))
    image.pack()
    mat, tree, bsdf = principled_material(name)
    bsdf.inputs["Base Color"].default_value = (1, 1, 1, 1)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    nmap.inputs["Strength"].default_value = strength
    tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    mesh.uv_layers.new(name="UVMap").data.foreach_set("uv", [0, 0, 1, 0, 1, 1, 0, 1])
    mesh.materials.append(mat)
    ob = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(ob)
    return ob


@pytest.mark.parametrize("strength", [0.5, 2.0])
def test_exported_normal_strength_shades_as_cycles(empty_scene, tmp_path, strength):
    """Cycles renders a plane with a constant normal map under a sun of irradiance pi
    straight down: each pixel is cos(normal, up). The exported scale and bias, then
    normalised (as a renderer does), must give that cosine."""
    scene = bpy.context.scene
    colour = (0.85, 0.3, 0.8)
    _normal_mapped_plane("Bent", colour, strength)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = math.pi, 0.0
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 1.0
    cam.location = (0, 0, 3)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.world = bpy.data.worlds.new("Black")
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.max_bounces, scene.cycles.use_denoising = 4, 0, False
    scene.render.resolution_x = scene.render.resolution_y = 4
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(tmp_path / "cycles.exr")
    bpy.ops.render.render(write_still=True)
    from lantern.engine.image_io import read_image
    cycles = float(read_image(str(tmp_path / "cycles.exr"))[..., 0].mean())

    stage, _ = export_current()
    tex, _ = source(surface(stage, "Bent"), "normal")
    # Unauthored means UsdUVTexture's fallback: scale (1, 1, 1, 1), bias (0, 0, 0, 0).
    scale = np.array(tex.GetInput("scale").Get() if tex.GetInput("scale") else (1, 1, 1, 1))[:3]
    bias = np.array(tex.GetInput("bias").Get() if tex.GetInput("bias") else (0, 0, 0, 0))[:3]
    n = scale * np.array(colour) + bias
    assert n[2] / np.linalg.norm(n) == pytest.approx(cycles, abs=2e-3)
    # The strength matters here: strength 1 would shade differently.
    n1 = 2 * np.array(colour) - 1
    assert abs(n1[2] / np.linalg.norm(n1) - cycles) > 0.02


# --- the output node ---------------------------------------------------------------------

def _two_outputs(name, first_target, second_target, second_active=False):
    """Output 1 (first_target) <- red Principled; output 2 (second_target) <- green Diffuse."""
    mat, tree, bsdf = principled_material(name)
    bsdf.inputs["Base Color"].default_value = (1, 0, 0, 1)
    first = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    first.target = first_target
    first.name = "Out A"
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0, 1, 0, 1)
    second = tree.nodes.new("ShaderNodeOutputMaterial")
    second.target = second_target
    second.name = "Out B"
    tree.links.new(diffuse.outputs["BSDF"], second.inputs["Surface"])
    if second_active:
        second.is_active_output = True
    return mat


def test_output_node_eevee_and_cycles_exports_cycles_with_a_warning(empty_scene):
    """No All output: Lantern exports what Cycles renders, and says the targets differ."""
    cube_object("C").data.materials.append(_two_outputs("Split", "EEVEE", "CYCLES"))
    stage, report = export_current()
    assert tuple(surface(stage, "Split").GetInput("diffuseColor").Get()) == pytest.approx((0, 1, 0))
    assert any("Split" in w and "Out A" in w and "Out B" in w for w in report.warnings), report.warnings


def test_output_node_all_wins_as_in_blenders_usd_exporter(empty_scene):
    """An All output and a Cycles output: Blender's USD exporter takes All (as
    ntreeShaderOutputNode(tree, SHD_OUTPUT_ALL)); the difference is a warning."""
    cube_object("C").data.materials.append(_two_outputs("AllAndCycles", "ALL", "CYCLES"))
    cube_object("D").data.materials.append(_two_outputs("TwoAll", "ALL", "ALL", second_active=True))
    stage, report = export_current()
    assert tuple(surface(stage, "AllAndCycles").GetInput("diffuseColor").Get()) == pytest.approx((1, 0, 0))
    assert any("AllAndCycles" in w for w in report.warnings)
    # Two All outputs: the active one, and no warning (every engine renders it).
    assert tuple(surface(stage, "TwoAll").GetInput("diffuseColor").Get()) == pytest.approx((0, 1, 0))
    assert not any("TwoAll" in w for w in report.warnings)


# --- emission -----------------------------------------------------------------------------

def test_emission_adds_up_and_mix_factors_weight_it(empty_scene, tmp_path):
    mat, tree, bsdf = principled_material("Glow")
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 2.0
    emit = tree.nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = (0.0, 0.2, 1.0, 1.0)
    emit.inputs["Strength"].default_value = 5.0
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.25
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree.links.new(bsdf.outputs["BSDF"], mix.inputs[1])
    tree.links.new(emit.outputs["Emission"], mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    cube_object("C").data.materials.append(mat)

    mat2, tree2, bsdf2 = principled_material("Added")
    bsdf2.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf2.inputs["Emission Strength"].default_value = 0.5
    emit2 = tree2.nodes.new("ShaderNodeEmission")
    emit2.inputs["Strength"].default_value = 3.0
    add = tree2.nodes.new("ShaderNodeAddShader")
    out2 = next(n for n in tree2.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree2.links.new(bsdf2.outputs["BSDF"], add.inputs[0])
    tree2.links.new(emit2.outputs["Emission"], add.inputs[1])
    tree2.links.new(add.outputs["Shader"], out2.inputs["Surface"])
    cube_object("D").data.materials.append(mat2)

    mat3, tree3, bsdf3 = principled_material("TexGlow")
    tex = tree3.nodes.new("ShaderNodeTexImage")
    tex.image = saved_image(tmp_path, "glow", "sRGB")
    tree3.links.new(tex.outputs["Color"], bsdf3.inputs["Emission Color"])
    bsdf3.inputs["Emission Strength"].default_value = 3.0
    cube_object("E").data.materials.append(mat3)
    stage, report = export_current()

    # 0.75 x (1, .5, .25) x 2 + 0.25 x (0, .2, 1) x 5
    assert tuple(surface(stage, "Glow").GetInput("emissiveColor").Get()) == \
        pytest.approx((1.5, 1.0, 1.625), rel=1e-6)
    assert any("Glow" in w and "Mix" in w for w in report.warnings)
    assert tuple(surface(stage, "Added").GetInput("emissiveColor").Get()) == pytest.approx((3.5, 3.5, 3.5))
    shader, _ = source(surface(stage, "TexGlow"), "emissiveColor")
    assert tuple(shader.GetInput("scale").Get()) == (3, 3, 3, 1)


# --- clearcoat ------------------------------------------------------------------------------

def test_coat_weight_and_roughness_are_clearcoat(empty_scene, tmp_path):
    mat, tree, bsdf = principled_material("Coated")
    bsdf.inputs["Coat Weight"].default_value = 0.7
    bsdf.inputs["Coat Roughness"].default_value = 0.2
    mat2, tree2, bsdf2 = principled_material("CoatMap")
    tex = tree2.nodes.new("ShaderNodeTexImage")
    tex.image = saved_image(tmp_path, "coat", "Non-Color")
    tree2.links.new(tex.outputs["Color"], bsdf2.inputs["Coat Weight"])
    bsdf2.inputs["Coat IOR"].default_value = 1.8
    mat3, _, _ = principled_material("Uncoated")
    for name, m in (("A", mat), ("B", mat2), ("C", mat3)):
        cube_object(name).data.materials.append(m)
    stage, report = export_current()
    s = surface(stage, "Coated")
    assert s.GetInput("clearcoat").Get() == pytest.approx(0.7)
    assert s.GetInput("clearcoatRoughness").Get() == pytest.approx(0.2)
    shader, out = source(surface(stage, "CoatMap"), "clearcoat")
    assert out == "r" and shader.GetInput("sourceColorSpace").Get() == "raw"
    assert any("CoatMap" in w and "Coat IOR" in w for w in report.warnings)
    assert surface(stage, "Uncoated").GetInput("clearcoat").Get() == 0.0
    assert not any("Coated" in w or "Uncoated" in w for w in report.warnings)


# --- packed and generated images --------------------------------------------------------

def _packed_and_generated(tmp_path):
    """A packed PNG (its file deleted) and a generated float image on two materials."""
    from lantern.engine.image_io import read_image
    src = saved_image(tmp_path, "packme", "sRGB")
    src.pixels.foreach_set(np.tile(np.array([0.2, 0.4, 0.6, 1.0], np.float32), 16))
    src.save()
    expected_png = read_image(str(tmp_path / "packme.png"))
    src.pack()
    os.remove(tmp_path / "packme.png")
    gen = bpy.data.images.new("made", 3, 2, float_buffer=True)
    values = np.arange(24, dtype=np.float32).reshape(2, 3, 4) / 4.0   # above 1 too
    gen.pixels.foreach_set(values.ravel())
    for name, image in (("Packed", src), ("Generated", gen)):
        image_on_base_cube(name, image, obj=name)
    return expected_png, values[::-1]          # Blender's rows run bottom-up


def _texture_file(stage, name):
    shader, _ = source(surface(stage, name), "diffuseColor")
    return shader.GetInput("file").Get().resolvedPath


def test_packed_and_generated_images_are_copied_with_the_file(empty_scene, tmp_path):
    from lantern.engine.image_io import read_image
    from lantern.exporters import ExportOptions, export_depsgraph_to_file
    png, floats = _packed_and_generated(tmp_path)
    out = tmp_path / "out" / "scene.usda"
    report = export_depsgraph_to_file(bpy.context.evaluated_depsgraph_get(), str(out),
                                      ExportOptions(textures="copy"))
    assert not [w for w in report.warnings if "packme" in w or "made" in w], report.warnings
    stage = Usd.Stage.Open(str(out))
    packed, generated = _texture_file(stage, "Packed"), _texture_file(stage, "Generated")
    assert os.path.dirname(packed) == os.path.dirname(generated) == str(tmp_path / "out" / "scene_textures")
    assert np.array_equal(read_image(packed), png)
    assert np.array_equal(read_image(generated), floats)


def test_packed_and_generated_images_render_from_memory(empty_scene, tmp_path):
    """An in-memory stage (rendering a .blend, F12): the images are written once per
    content into this process's temporary folder, readable by the engine."""
    from lantern.engine.image_io import read_image
    from lantern.exporters.gather.image import memory_texture_dir
    png, floats = _packed_and_generated(tmp_path)
    stage, report = export_current()
    assert not [w for w in report.warnings if "packme" in w or "made" in w], report.warnings
    packed, generated = _texture_file(stage, "Packed"), _texture_file(stage, "Generated")
    assert os.path.dirname(packed) == memory_texture_dir()
    assert np.array_equal(read_image(packed), png)
    assert np.array_equal(read_image(generated), floats)
    before = sorted(os.listdir(memory_texture_dir()))
    again, _ = export_current()
    assert _texture_file(again, "Packed") == packed
    assert sorted(os.listdir(memory_texture_dir())) == before   # nothing new written


def test_generated_byte_image_keeps_its_bytes(empty_scene, tmp_path):
    """Not through save_render: the scene's view transform must not be baked in."""
    from lantern.engine.image_io import read_image
    bpy.context.scene.view_settings.view_transform = "AgX"
    img = bpy.data.images.new("grid", 8, 8, alpha=True)
    img.generated_type = "COLOR_GRID"
    image_on_base_cube("Grid", img)
    stage, _ = export_current()
    pixels = np.empty(8 * 8 * 4, np.float32)
    img.pixels.foreach_get(pixels)
    expected = np.round(pixels.reshape(8, 8, 4)[::-1] * 255).astype(np.uint8)
    assert np.array_equal(read_image(_texture_file(stage, "Grid")), expected)


def test_packed_texture_renders_in_09_tex_wrapping_mirror(corpus):
    """09_tex_wrapping_mirror's texture is packed: before this fix `lantern render
    scene.blend` lost it (the quads took the socket colour). Textured area against
    the Cycles reference: see tests/references/looks/BEFORE.md for the figures."""
    import reference_scenes
    from lantern.engine import RenderSettings, read_exr, render_stage
    from lantern.engine.bounces import DIRECT
    from lantern.exporters import stage_from_depsgraph
    import tempfile
    reference_scenes.build("09_tex_wrapping_mirror", tempfile.mkdtemp())
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert not [w for w in report.warnings if "Black" in w], report.warnings
    width, height = reference_scenes.SCENES["09_tex_wrapping_mirror"].size
    # Direct light, as the reference (tests/references/make_cycles_references.py).
    ours = render_stage(stage, RenderSettings(width=width, height=height,
                                              bounces=DIRECT)).rgba[..., :3]
    cycles = read_exr(str(reference_scenes.REPO / "tests" / "references" / "looks"
                          / "09_tex_wrapping_mirror.exr"))[..., :3]
    background = cycles[0, 0]
    textured = np.abs(cycles - background).max(-1) > 0.5 * background.max()
    assert textured.mean() > 0.2
    lantern_mean, cycles_mean = ours[textured].mean(), cycles[textured].mean()
    print(f"textured area: Lantern {lantern_mean:.5f}, Cycles {cycles_mean:.5f}")
    assert abs(lantern_mean - cycles_mean) <= 0.1 * background.max()


# --- the world ------------------------------------------------------------------------------

def _world_with_map(path, rotation=None):
    world = bpy.data.worlds.new("Sky")
    nodes, links = world.node_tree.nodes, world.node_tree.links
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(path))
    links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
    if rotation is not None:
        mapping = nodes.new("ShaderNodeMapping")
        mapping.inputs["Rotation"].default_value = rotation
        coords = nodes.new("ShaderNodeTexCoord")
        links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    bpy.context.scene.world = world
    return world


def blender_direction(u, v, rotation):
    """The world direction Blender's Environment Texture shows texel (u, v) at (v = 0 the
    top row): Cycles' equirectangular_to_direction, then the Mapping node's inverse
    rotation (it looks the texture up at R d)."""
    from mathutils import Euler, Vector
    phi, theta = math.pi - 2 * math.pi * u, math.pi * v
    b = Vector((math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)))
    return np.array(Euler(rotation, "XYZ").to_matrix().inverted() @ b)


def usdlux_direction(stage, u, v):
    """The world direction the stage's DomeLight shows texel (u, v) at, by UsdLux's
    documented convention (the OpenEXR lat-long in the light's frame, +Y up):
    longitude pi - 2 pi u, latitude pi/2 - pi v, local (cos lat sin lon, sin lat,
    cos lat cos lon), then the prim's local-to-world transform. pxr math only."""
    dome = UsdLux.DomeLight(stage.GetPrimAtPath("/root/_world"))
    assert dome.GetTextureFormatAttr().Get() == "latlong"
    lon, lat = math.pi - 2 * math.pi * u, math.pi / 2 - math.pi * v
    local = Gf.Vec3d(math.cos(lat) * math.sin(lon), math.sin(lat), math.cos(lat) * math.cos(lon))
    world = UsdGeom.Xformable(dome).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    return np.array(world.TransformDir(local).GetNormalized())


@pytest.mark.parametrize("rotation", [None, (0.3, -0.5, 1.2)])
def test_dome_shows_each_texel_where_blender_does(empty_scene, tmp_path, rotation):
    """An asymmetric map with marked texels: for each, the direction Blender's world
    shows it at equals the direction the exported DomeLight shows it at."""
    from lantern.engine.image_io import write_image
    h, w = 16, 32
    marks = [(3, 5), (8, 8), (8, 16), (8, 24), (12, 29), (0, 0), (15, 31)]
    sky = np.zeros((h, w, 4), np.float32)
    sky[..., 3] = 1.0
    for i, (r, c) in enumerate(marks):
        sky[r, c, :3] = (1.0 + i, 0.5, 0.25)
    write_image(str(tmp_path / "marks.exr"), sky)
    _world_with_map(tmp_path / "marks.exr", rotation)
    stage, report = export_current()
    assert report.warnings == []
    for r, c in marks:
        u, v = (c + 0.5) / w, (r + 0.5) / h
        expected = blender_direction(u, v, rotation or (0.0, 0.0, 0.0))
        assert usdlux_direction(stage, u, v) == pytest.approx(expected, abs=1e-6), (r, c)
    # The image centre looks along +X, a quarter in along +Y, the top row up (+Z).
    assert usdlux_direction(stage, 0.5, 0.5) == pytest.approx(blender_direction(0.5, 0.5, rotation or (0, 0, 0)), abs=1e-6)
    if rotation is None:
        assert usdlux_direction(stage, 0.5, 0.5) == pytest.approx((1, 0, 0), abs=1e-6)
        assert usdlux_direction(stage, 0.25, 0.5) == pytest.approx((0, 1, 0), abs=1e-6)
        assert usdlux_direction(stage, 0.5, 0.0) == pytest.approx((0, 0, 1), abs=1e-6)


def test_packed_environment_image_is_exported(empty_scene, tmp_path):
    from lantern.engine.image_io import read_image, write_image
    sky = np.full((4, 8, 4), 2.5, np.float32)
    write_image(str(tmp_path / "sky.exr"), sky)
    world = _world_with_map(tmp_path / "sky.exr")
    world.node_tree.nodes["Environment Texture"].image.pack()
    os.remove(tmp_path / "sky.exr")
    stage, report = export_current()
    assert report.warnings == []
    dome = UsdLux.DomeLight(stage.GetPrimAtPath("/root/_world"))
    assert np.array_equal(read_image(dome.GetTextureFileAttr().Get().resolvedPath), sky)


def _render_unlit_world(stage):
    """The stage under a uniform white world only, from a fixed view."""
    from lantern.engine import RenderSettings, render_stage
    dome = UsdLux.DomeLight.Define(stage, "/root/World")
    dome.CreateColorAttr(Gf.Vec3f(1.0, 1.0, 1.0))
    return render_stage(stage, RenderSettings(width=48, height=32, preset="low")).rgba


def test_faces_without_a_material_shade_as_blenders_default_surface(empty_scene):
    """Cycles renders a face without a material with a 0.8 grey diffuse surface; USD's
    fallback (UsdPreviewSurface's 0.18) rendered 29_armature_use_current_pose's cube a
    quarter as bright as Cycles. The exporter writes that colour as displayColor: a
    mesh without a material renders as one with Blender's default Principled BSDF."""
    cube_object("Bare")
    stage, _ = export_current()
    bare = UsdGeom.Mesh(stage.GetPrimAtPath("/root/Bare/Bare_mesh") or
                        next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)))
    assert tuple(bare.GetDisplayColorAttr().Get()[0]) == pytest.approx((0.8, 0.8, 0.8))
    unbound = _render_unlit_world(stage)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat, _, _ = principled_material("Default")
    cube_object("Bare").data.materials.append(mat)
    stage, _ = export_current()
    mesh = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    assert not UsdGeom.Mesh(mesh).GetDisplayColorAttr().HasAuthoredValue()
    bound = _render_unlit_world(stage)
    assert unbound[..., :3].max() > 0.5
    assert np.abs(unbound - bound).max() < 0.02


def test_an_empty_material_slot_gets_the_default_surface_colour(empty_scene):
    mat, tree, bsdf = principled_material("Red")
    bsdf.inputs["Base Color"].default_value = (1.0, 0.0, 0.0, 1.0)
    ob = cube_object("TwoSlots")
    ob.data.materials.append(mat)
    ob.data.materials.append(None)
    for polygon in ob.data.polygons:
        polygon.material_index = polygon.index % 2
    stage, _ = export_current()
    mesh = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    assert tuple(UsdGeom.Mesh(mesh).GetDisplayColorAttr().Get()[0]) == pytest.approx((0.8, 0.8, 0.8))
    bound = [UsdShade.MaterialBindingAPI(s.GetPrim()).ComputeBoundMaterial()[0]
             for s in UsdShade.MaterialBindingAPI(mesh).GetMaterialBindSubsets()]
    assert sorted(bool(m) for m in bound) == [False, True]


def test_a_network_on_an_input_that_takes_constants_names_the_input(empty_scene):
    """Coat Weight takes no network: the warning names the input and the node (a
    supported one), not "not supported"."""
    mat, tree, bsdf = principled_material("Coated")
    half = tree.nodes.new("ShaderNodeMath")
    half.operation = "MULTIPLY"
    half.inputs[0].default_value, half.inputs[1].default_value = 0.5, 0.5
    tree.links.new(half.outputs[0], bsdf.inputs["Coat Weight"])
    cube_object("Cube").data.materials.append(mat)
    _, report = export_current()
    assert len(report.warnings) == 1, report.warnings
    assert "'Coat Weight' takes a constant only" in report.warnings[0] and \
        "ShaderNodeMath" in report.warnings[0] and "not supported" not in report.warnings[0]


def test_an_ambient_occlusion_nodes_color_on_base_color_marks_the_material(empty_scene):
    """AO Color -> Base Color: the base colour is the node's Color input, and the
    material says the renderer's occlusion multiplies it; its AO output elsewhere is
    still one warning."""
    mat, tree, bsdf = principled_material("Occluded")
    ao = tree.nodes.new("ShaderNodeAmbientOcclusion")
    ao.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    tree.links.new(ao.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(ao.outputs["AO"], bsdf.inputs["Roughness"])
    cube_object("Cube").data.materials.append(mat)
    stage, report = export_current()
    prim = stage.GetPrimAtPath("/root/_materials/Occluded")
    assert prim.GetAttribute("lantern:baseColorOcclusion").Get() is True
    assert tuple(surface(stage, "Occluded").GetInput("diffuseColor").Get()) == \
        pytest.approx((0.2, 0.4, 0.6))
    assert len(report.warnings) == 1 and "Ambient Occlusion" in report.warnings[0], \
        report.warnings


def test_an_add_shader_of_two_bsdfs_adds_their_base_colours(empty_scene):
    """Add Shader of two Principled BSDFs (no specular): one layer whose base colour is
    the sum, no warning; with a Glossy BSDF (not mixable) one warning says so."""
    mat, tree, bsdf = principled_material("Added")
    bsdf.inputs["Base Color"].default_value = (0.4, 0.1, 0.05, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    second = tree.nodes.new("ShaderNodeBsdfPrincipled")
    second.inputs["Base Color"].default_value = (0.1, 0.2, 0.4, 1.0)
    second.inputs["Specular IOR Level"].default_value = 0.0
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(bsdf.outputs["BSDF"], add.inputs[0])
    tree.links.new(second.outputs["BSDF"], add.inputs[1])
    tree.links.new(add.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    cube_object("Cube").data.materials.append(mat)
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    assert tuple(surface(stage, "Added").GetInput("diffuseColor").Get()) == \
        pytest.approx((0.5, 0.3, 0.45))
    tree.links.new(tree.nodes.new("ShaderNodeBsdfAnisotropic").outputs[0], add.inputs[1])
    _, report = export_current()
    assert [w for w in report.warnings if "Add Shader" in w and "Added" in w], report.warnings


def test_a_material_reading_two_attributes_is_one_warning(empty_scene):
    ob = cube_object("Two")
    for name in ("A", "B"):
        ob.data.color_attributes.new(name, "FLOAT_COLOR", "POINT")
    mat, tree, bsdf = principled_material("ReadsTwo")
    first, second = (tree.nodes.new("ShaderNodeVertexColor") for _ in range(2))
    first.layer_name, second.layer_name = "A", "B"
    tree.links.new(first.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(second.outputs["Color"], bsdf.inputs["Emission Color"])
    bsdf.inputs["Emission Strength"].default_value = 1.0
    ob.data.materials.append(mat)
    _, report = export_current()
    assert len(report.warnings) == 1 and "'A', 'B'" in report.warnings[0] and \
        "ReadsTwo" in report.warnings[0], report.warnings


def _sheen(stage, name):
    prim = stage.GetPrimAtPath(f"/root/_materials/{name}")
    mode = prim.GetAttribute("lantern:sheenMode")
    if not mode:
        return None
    return (mode.Get(), tuple(prim.GetAttribute("lantern:sheenColor").Get()),
            prim.GetAttribute("lantern:sheenRoughness").Get())


def test_sheen_is_the_principled_bsdfs_or_a_sheen_bsdfs(empty_scene):
    """The Principled BSDF's sheen (weight x tint, layered) and a Sheen BSDF added to it
    or alone (its distribution) are one sheen lobe each, weighted exactly by a Mix
    Shader, and networks on its colour and roughness feed the pattern graph; a second
    sheen is one warning."""
    mat, tree, bsdf = principled_material("Fabric")
    bsdf.inputs["Sheen Weight"].default_value = 0.5
    bsdf.inputs["Sheen Tint"].default_value = (1.0, 0.5, 0.25, 1.0)
    bsdf.inputs["Sheen Roughness"].default_value = 0.3
    cube_object("Cube").data.materials.append(mat)
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    mode, color, roughness = _sheen(stage, "Fabric")
    assert mode == "principled" and color == pytest.approx((0.5, 0.25, 0.125))
    assert roughness == pytest.approx(0.3)

    # The glTF importer's older velvet: a Sheen BSDF added to the Principled BSDF.
    bsdf.inputs["Sheen Weight"].default_value = 0.0
    velvet = tree.nodes.new("ShaderNodeBsdfSheen")
    velvet.distribution = "ASHIKHMIN"
    velvet.inputs["Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    velvet.inputs["Roughness"].default_value = 0.6
    add = tree.nodes.new("ShaderNodeAddShader")
    out = tree.nodes["Material Output"].inputs["Surface"]
    tree.links.new(bsdf.outputs[0], add.inputs[0])
    tree.links.new(velvet.outputs[0], add.inputs[1])
    tree.links.new(add.outputs[0], out)
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    assert _sheen(stage, "Fabric")[0] == "ashikhmin"
    assert _sheen(stage, "Fabric")[1] == pytest.approx((0.1, 0.2, 0.3))

    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs[0].default_value = 0.25
    tree.links.new(bsdf.outputs[0], mix.inputs[1])
    tree.links.new(velvet.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out)
    stage, report = export_current()
    assert _sheen(stage, "Fabric")[1] == pytest.approx((0.025, 0.05, 0.075))
    assert len(report.warnings) == 1 and "BSDF weights" in report.warnings[0], report.warnings

    tree.links.new(velvet.outputs[0], out)             # alone: nothing else reflects
    velvet.distribution = "MICROFIBER"
    stage, report = export_current()
    assert report.warnings == [] and _sheen(stage, "Fabric")[0] == "microfiber"
    assert tuple(surface(stage, "Fabric").GetInput("diffuseColor").Get()) == (0, 0, 0)

    # A network on the sheen's colour and roughness: the pattern graph's sheenColor and
    # sheenRoughness (the constants stay the fallback).
    tree.links.new(tree.nodes.new("ShaderNodeTexChecker").outputs["Color"],
                   velvet.inputs["Color"])
    math = tree.nodes.new("ShaderNodeMath")
    tree.links.new(math.outputs[0], velvet.inputs["Roughness"])
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    mtlx = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/Fabric/MtlxSurface"))
    assert all(mtlx.GetInput(n).HasConnectedSource() for n in ("sheenColor", "sheenRoughness"))

    tree.links.new(add.outputs[0], out)
    bsdf.inputs["Sheen Weight"].default_value = 1.0
    stage, report = export_current()
    assert _sheen(stage, "Fabric")[0] == "principled"
    assert any("second sheen" in w for w in report.warnings), report.warnings
    assert not any("not supported" in w for w in report.warnings), report.warnings


def _gltf_quad(path, png, mag_filter):
    """A glTF 2.0 file of one textured quad whose sampler has `mag_filter` (9728
    NEAREST, 9729 LINEAR) and the same minification filter, its image `png`."""
    import base64
    import json
    positions = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], np.float32)
    uvs = np.array([(0, 1), (1, 1), (1, 0), (0, 0)], np.float32)
    indices = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blob = positions.tobytes() + uvs.tobytes() + indices.tobytes()
    views = [(0, 48, 34962), (48, 32, 34962), (80, 12, 34963)]
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1},
                                    "indices": 2, "material": 0}]}],
        "materials": [{"name": "Pixels", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"magFilter": mag_filter, "minFilter": mag_filter}],
        "images": [{"uri": os.path.basename(png)}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(blob).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": n, "target": t}
                        for o, n, t in views],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    }
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("mag_filter, filtertype", [(9728, "closest"), (9729, None)])
def test_the_gltf_importers_nearest_sampler_is_exported_as_closest(empty_scene, tmp_path,
                                                                   mag_filter, filtertype):
    """Blender's glTF importer reads a NEAREST sampler as the Image Texture's Closest
    (pixel art, low-poly assets); the UsdUVTexture says so in lantern:filtertype, which
    is not written for Linear (UsdUVTexture has no input for it: the stage contract,
    "Textures")."""
    png = saved_image(tmp_path, "pixels", "sRGB").filepath_raw
    bpy.ops.import_scene.gltf(filepath=str(_gltf_quad(tmp_path / "quad.gltf", png, mag_filter)))
    stage, report = export_current()
    assert report.warnings == []
    tex, _ = source(surface(stage, "Pixels"), "diffuseColor")
    attr = tex.GetPrim().GetAttribute("lantern:filtertype")
    assert (attr.Get() if attr and attr.HasAuthoredValue() else None) == filtertype


def _read_back(stage, name):
    """The engine's record of an exported material (engine/usd/materials.py)."""
    from lantern.engine.usd.materials import read_material
    warnings = []
    mat = read_material(UsdShade.Material(stage.GetPrimAtPath(f"/root/_materials/{name}")),
                        Usd.TimeCode.Default(), warnings)
    assert warnings == []
    return mat


def test_glass_is_transmission_with_opacity_and_ior_for_other_readers(empty_scene):
    """The Principled BSDF's Transmission, the Glass BSDF and the Refraction BSDF are
    lantern:transmission on the Material prim, with `opacity` 1 - transmission and
    `ior` the IOR (what any UsdPreviewSurface reader draws as translucent), the tint as
    the base colour and the roughness as the roughness, on the MaterialX surface too;
    the engine reads them back as glass."""
    mat, tree, bsdf = principled_material("Glass")
    bsdf.inputs["Base Color"].default_value = (0.9, 0.8, 0.7, 1.0)
    bsdf.inputs["Transmission Weight"].default_value = 0.75
    bsdf.inputs["IOR"].default_value = 1.45
    bsdf.inputs["Roughness"].default_value = 0.1
    tree.links.new(tree.nodes.new("ShaderNodeTexChecker").outputs["Fac"],
                   bsdf.inputs["Roughness"])          # a network: the MaterialX surface
    cube_object("C").data.materials.append(mat)
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    s = surface(stage, "Glass")
    assert s.GetInput("opacity").Get() == pytest.approx(0.25)
    assert s.GetInput("ior").Get() == pytest.approx(1.45, rel=1e-5)
    assert tuple(s.GetInput("diffuseColor").Get()) == pytest.approx((0.9, 0.8, 0.7))
    prim = stage.GetPrimAtPath("/root/_materials/Glass")
    assert prim.GetAttribute("lantern:transmission").Get() == pytest.approx(0.75)
    assert not prim.GetAttribute("lantern:alphaMode")       # not Dithered alpha
    mtlx = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/Glass/MtlxSurface"))
    assert mtlx.GetInput("opacity").Get() == pytest.approx(0.25)
    assert mtlx.GetInput("ior").Get() == pytest.approx(1.45, rel=1e-5)
    read = _read_back(stage, "Glass")
    assert read.transmission == pytest.approx(0.75) and read.alpha == "glass"
    assert read.opacity == 1.0 and read.ior == pytest.approx(1.45, rel=1e-5)

    for kind in ("ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"):
        node = tree.nodes.new(kind)
        node.inputs["Color"].default_value = (0.5, 0.9, 0.6, 1.0)
        node.inputs["Roughness"].default_value = 0.2
        node.inputs["IOR"].default_value = 1.33
        tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
        stage, report = export_current()
        assert report.warnings == [], (kind, report.warnings)
        s = surface(stage, "Glass")
        assert s.GetInput("opacity").Get() == 0.0 and s.GetInput("metallic").Get() == 0.0
        assert s.GetInput("ior").Get() == pytest.approx(1.33)
        assert s.GetInput("roughness").Get() == pytest.approx(0.2)
        read = _read_back(stage, "Glass")
        assert read.transmission == 1.0 and read.diffuse == pytest.approx((0.5, 0.9, 0.6))

    # Alpha below 1 on glass: one warning, and the glass is whole.
    tree.links.new(bsdf.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    bsdf.inputs["Alpha"].default_value = 0.5
    stage, report = export_current()
    assert len(report.warnings) == 1 and "Alpha of a transmissive" in report.warnings[0]
    assert surface(stage, "Glass").GetInput("opacity").Get() == pytest.approx(0.25)
    # No transmission: nothing of glass is written.
    bsdf.inputs["Transmission Weight"].default_value = 0.0
    stage, report = export_current()
    assert not stage.GetPrimAtPath("/root/_materials/Glass").GetAttribute("lantern:transmission")
    assert _read_back(stage, "Glass").alpha == "blend"
