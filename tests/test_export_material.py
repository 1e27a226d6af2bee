"""Principled BSDF -> UsdPreviewSurface, textures, warnings."""
import bpy
import pytest
from pxr import UsdShade

from _export_helpers import cube_object, export_current
from lantern.exporters.gather.material import principled_ior


def principled_material(name):
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    return mat, tree, bsdf


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


def test_normal_map(empty_scene, tmp_path):
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


def test_unknown_node_warns_with_material_and_node(empty_scene):
    mat, tree, bsdf = principled_material("Noisy")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.name = "My Noise"
    tree.links.new(noise.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Base Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    cube_object("C").data.materials.append(mat)
    stage, report = export_current()
    assert any("Noisy" in w and "My Noise" in w for w in report.warnings), report.warnings
    # The fallback is the socket's own constant.
    assert tuple(surface(stage, "Noisy").GetInput("diffuseColor").Get()) == \
        pytest.approx((0.1, 0.2, 0.3))


def test_missing_image_warns_and_falls_back(empty_scene, tmp_path):
    mat, tree, bsdf = principled_material("Lost")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.new("gone", 2, 2)
    tex.image.source = "FILE"
    tex.image.filepath = str(tmp_path / "gone.png")
    tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    cube_object("C").data.materials.append(mat)
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
