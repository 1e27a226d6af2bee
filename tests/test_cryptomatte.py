"""Cryptomatte: ids as the specification hashes them, ranks and coverage from the
preset's samples, and a file that Blender's own compositor picks mattes from.

The scene: two boxes turned about the view axis, seen from above through an
orthographic camera, the front one (higher) partly over the back one, nothing
behind them: edge pixels see front and back, or a box and nothing."""
import json
import math
import struct

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

import cryptomatte_reader as reader
from lantern.core import cryptomatte
from lantern.core.passes import options
from lantern.engine import RenderSettings, Session

W, H = 48, 27
MATTES = frozenset(options()["crypto_object"] + options()["crypto_material"] +
                   options()["crypto_asset"])
FRONT, BACK = "/root/front/box", "/root/back/box"


def _material(stage, name, colour):
    mat = UsdShade.Material.Define(stage, f"/root/_materials/{name}")
    sh = UsdShade.Shader.Define(stage, f"/root/_materials/{name}/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*colour))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def _box(stage, parent, centre, size, turn, material, index):
    xf = UsdGeom.Xform.Define(stage, parent)
    xf.AddTranslateOp().Set(Gf.Vec3d(*centre))
    xf.AddRotateZOp().Set(turn)
    xf.GetPrim().CreateAttribute("lantern:passIndex", Sdf.ValueTypeNames.Int,
                                 custom=True).Set(index)
    s = size / 2
    mesh = UsdGeom.Mesh.Define(stage, f"{parent}/box")
    mesh.CreateSubdivisionSchemeAttr("none")
    corners = [(x, y, z) for z in (-s, s) for y in (-s, s) for x in (-s, s)]
    mesh.CreatePointsAttr(corners)
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr([0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4,
                                      2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def scene():
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/root").GetPrim())
    red, blue = _material(stage, "red", (0.8, 0.1, 0.1)), _material(stage, "blue", (0.1, 0.1, 0.8))
    _box(stage, "/root/back", (-0.35, 0.1, 0.5), 1.6, 17.0, red, 1)
    _box(stage, "/root/front", (0.55, -0.2, 1.5), 1.2, -31.0, blue, 2)
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    cam.CreateHorizontalApertureAttr(40.0)          # 4 m wide (tenths of a unit)
    cam.CreateVerticalApertureAttr(40.0 * H / W)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 10.0))
    return stage


def _render(preset, size=(W, H), passes=MATTES, transparent=True, compute=None,
            supersample=None):
    with Session(scene(), RenderSettings(width=size[0], height=size[1], preset=preset,
                                         passes=passes, transparent=transparent,
                                         compute=compute, supersample=supersample)) as s:
        return s.render()


def _coverage(result, matte, name):
    """One name's matte from the passes, decoded as the specification says."""
    channels = {}
    for level in range(3):
        a = result.passes[f"{matte}{level:02d}"]
        for k, c in enumerate("rgba"):
            channels[f"{matte}{level:02d}.{c}"] = a[..., k]
    return reader.coverage(channels, matte, cryptomatte.name_id(name))


def test_ids_are_the_specifications_murmur3_floats():
    """The ids and layer keys Blender writes for the same names (its manifest of a
    default scene: Cycles, 5.0.1)."""
    for name, digits in (("Cube", "a8fce865"), ("Light", "c77d43e5"),
                         ("Material", "3913209d"), ("World", "89408cc1"),
                         ("default_surface", "78d05529")):
        assert cryptomatte.id_hex(name) == digits
        assert struct.pack(">f", cryptomatte.name_id(name)).hex() == digits
    assert cryptomatte.layer_key("ViewLayer.CryptoObject") == "542cafa"
    assert cryptomatte.layer_key("ViewLayer.CryptoMaterial") == "c7dbf5e"
    # The conversion keeps every id a normal float: no 0, denormal, Inf or NaN.
    for name in (f"/root/object_{i}" for i in range(2000)):
        f = abs(cryptomatte.name_id(name))
        assert math.isfinite(f) and f >= np.finfo(np.float32).tiny
    meta = cryptomatte.metadata("ViewLayer.CryptoObject", {"/a": cryptomatte.id_hex("/a")})
    assert json.loads(meta["cryptomatte/542cafa/manifest"]) == {"/a": cryptomatte.id_hex("/a")}


@pytest.fixture(scope="module")
def ultra():
    """Ultra (3x3 supersampled) mattes and alpha, and each sub-pixel's object: the same
    view drawn 3 times wider and taller at low (one sample a pixel) by object index."""
    mattes = _render("ultra")
    samples = _render("low", (3 * W, 3 * H), frozenset(["IndexOB"]), False)
    return mattes, samples.passes["IndexOB"][..., 0]


def test_ultra_coverage_is_the_share_of_each_objects_samples(ultra):
    """At ultra each pixel has 9 samples: an object's coverage is the share of them it
    covers (a box over the pixel's own samples, exact), so an edge pixel's coverage is
    within 1/9 of it, and a pixel's ranks sum to the share of its samples that see any
    surface. Also printed: how far the beauty's filter (Blackman-Harris, 1.5 px) would
    put the coverage from that share, had it weighted the samples instead."""
    from image_metrics import downsample
    result, index = ultra
    total = np.zeros((H, W))
    worst, worst_filter = 0.0, 0.0
    for name, value in ((BACK, 1.0), (FRONT, 2.0)):
        mask = (index == value).astype(np.float32)
        own = mask.reshape(H, 3, W, 3).mean(axis=(1, 3))
        cov = _coverage(result, "CryptoObject", name)
        edge = (own > 0) & (own < 1)
        assert edge.sum() > 20, name
        worst = max(worst, float(np.abs(cov - own)[edge].max()))
        filtered = downsample(mask[..., None], 3)[..., 0]
        worst_filter = max(worst_filter, float(np.abs(filtered - own)[edge].max()))
        total += cov
    print(f"edge pixels: worst |coverage - share of the pixel's 9 samples| {worst:.2e}; "
          f"with the beauty's filter it would be {worst_filter:.3f} (1/9 = {1 / 9:.3f})")
    assert worst <= 1e-6 < 1 / 9
    seen = (index > 0).reshape(H, 3, W, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(total, seen, atol=1e-6)
    # Somewhere both boxes share a pixel: two ranks, each its own coverage, summing to
    # the pixel's coverage.
    front, back = (_coverage(result, "CryptoObject", n) for n in (FRONT, BACK))
    both = (front > 0) & (back > 0)
    assert both.sum() > 5
    ranks = result.passes["CryptoObject00"]
    np.testing.assert_allclose(ranks[both][:, 1] + ranks[both][:, 3], seen[both], atol=1e-6)
    assert (ranks[both][:, 1] >= ranks[both][:, 3]).all()       # by coverage


def test_materials_and_assets(ultra):
    """The material matte follows the bound Material prims, the asset matte the
    top-level prims under the default prim."""
    result, _ = ultra
    pairs = (("CryptoMaterial", "/root/_materials/blue", "CryptoObject", FRONT),
             ("CryptoMaterial", "/root/_materials/red", "CryptoObject", BACK),
             ("CryptoAsset", "/root/front", "CryptoObject", FRONT),
             ("CryptoAsset", "/root/back", "CryptoObject", BACK))
    for matte, name, by, obj in pairs:
        np.testing.assert_allclose(_coverage(result, matte, name),
                                   _coverage(result, by, obj), atol=1e-6)
    assert result.cryptomatte == {
        "CryptoObject": {n: cryptomatte.id_hex(n) for n in (BACK, FRONT)},
        "CryptoMaterial": {n: cryptomatte.id_hex(n)
                           for n in ("/root/_materials/blue", "/root/_materials/red")},
        "CryptoAsset": {n: cryptomatte.id_hex(n) for n in ("/root/back", "/root/front")}}


@pytest.mark.parametrize("preset", ["medium", "ultra"])
def test_both_forms_rank_alike(preset):
    """The pass's raster form (GL 3.3) and its compute form (GL 4.3) give the same
    mattes."""
    raster, compute = (_render(preset, compute=c) for c in (False, True))
    for name in MATTES:
        np.testing.assert_array_equal(raster.passes[name], compute.passes[name])


@pytest.mark.parametrize("preset", ["low", "medium"])
def test_one_sample_a_pixel_gives_coverage_0_or_1(preset):
    # One sample a pixel: low, and medium as a viewport draws it (medium supersamples
    # stills as small as this one).
    result = _render(preset, passes=frozenset(options()["crypto_object"]), supersample=1)
    ids, cov = result.passes["CryptoObject00"][..., 0], result.passes["CryptoObject00"][..., 1]
    assert set(np.unique(cov)) == {0.0, 1.0}
    assert set(np.unique(ids[cov == 1])) == {cryptomatte.name_id(FRONT),
                                              cryptomatte.name_id(BACK)}
    assert not result.passes["CryptoObject01"].any() and not result.passes["CryptoObject02"].any()


def test_blenders_compositor_picks_the_mattes_by_name(ultra, tmp_path):
    """Blender's compositor as a client: its Cryptomatte node in Image mode on the
    written EXR, an object and a material picked by name, gives their coverage."""
    import bpy
    from lantern.engine.image_io import write_layers
    result, _ = ultra
    path = tmp_path / "mattes.exr"
    write_layers(str(path), result.rgba, result.passes, cryptomatte=result.cryptomatte)
    header, channels = reader.read(path)
    types = reader.matte_types(header)
    assert set(types) == {"ViewLayer.CryptoObject", "ViewLayer.CryptoMaterial",
                          "ViewLayer.CryptoAsset"}
    for layer, name in (("CryptoObject", FRONT), ("CryptoObject", BACK),
                        ("CryptoMaterial", "/root/_materials/red")):
        matte = compositor_matte(path, f"ViewLayer.{layer}", name, tmp_path)
        expected = reader.coverage(channels, f"ViewLayer.{layer}",
                                   types[f"ViewLayer.{layer}"][name])
        print(f"{layer} {name}: compositor vs file, max difference "
              f"{np.abs(matte - expected).max():.2e}")
        np.testing.assert_allclose(matte, expected, atol=1e-5)
        np.testing.assert_allclose(matte, _coverage(result, layer, name), atol=1e-5)
    bpy.ops.wm.read_factory_settings(use_empty=True)


def compositor_matte(exr, layer, name, folder) -> np.ndarray:
    """The Matte output of Blender's Cryptomatte node (Image mode) picking `name` from
    `layer` of `exr`, rendered headless by Blender's compositor; row 0 = top."""
    import bpy
    from lantern.engine.image_io import read_exr
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    tree = bpy.data.node_groups.new("mattes", "CompositorNodeTree")
    scene.compositing_node_group = tree
    node = tree.nodes.new("CompositorNodeCryptomatteV2")
    node.source = 'IMAGE'
    node.image = bpy.data.images.load(str(exr))
    node.layer_name = layer
    node.matte_id = name
    out = tree.nodes.new("NodeGroupOutput")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    tree.links.new(node.outputs["Matte"], out.inputs[0])
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.filepath = str(folder / "matte.exr")
    bpy.ops.render.render(write_still=True)
    return read_exr(str(folder / "matte.exr"))[..., 0]
