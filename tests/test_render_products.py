"""`lantern render` writes render passes: `--passes` into one multi-layer EXR under
Blender's layer names, and the stage's UsdRender products (RenderSettings,
RenderProduct, RenderVar) as the files they name, here and on the farm."""
import os
import subprocess
import sys

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdRender

import shadow_scenes
from multilayer_exr import read_parts
from lantern.core import passes as table

DISTANCE = 5.0              # the camera above the plane, looking straight down
W, H = 64, 36


def lantern(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "lantern", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd)


def _stage():
    """The white plane z = 0 seen from DISTANCE straight above, a box on it, a sun."""
    stage = shadow_scenes.new_stage()
    stage.SetDefaultPrim(stage.GetPrimAtPath("/root"))
    shadow_scenes.add_box(stage, center=(1.0, 0.5, 0.4), size=0.8)
    shadow_scenes.add_light(stage, "sun", strength=2.0, dir=(0.3, 0.2, -1.0))
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateFocalLengthAttr(20.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(36.0 * H / W)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.05, 100.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, DISTANCE))
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(3)
    return stage


def _var(stage, name, source, source_type="raw"):
    var = UsdRender.Var.Define(stage, f"/Render/Vars/{name}")
    var.CreateSourceNameAttr(source)
    var.CreateSourceTypeAttr(source_type)
    return var.GetPath()


def _settings(stage):
    """The stage's RenderSettings: W x H through /root/cam."""
    settings = UsdRender.Settings.Define(stage, "/Render/rendersettings")
    settings.CreateResolutionAttr(Gf.Vec2i(W, H))
    settings.CreateCameraRel().SetTargets(["/root/cam"])
    return settings


def products_stage(path, aux_name="aux/data.$F4.exr"):
    """Two RenderProducts: the beauty at the settings' 64x36, and depth, CryptoObject
    and an LPE Lantern cannot make at half that."""
    stage = _stage()
    settings = _settings(stage)
    beauty = UsdRender.Product.Define(stage, "/Render/Products/beauty")
    beauty.CreateProductNameAttr("beauty.$F4.exr")
    beauty.CreateOrderedVarsRel().SetTargets([_var(stage, "color", "color")])
    aux = UsdRender.Product.Define(stage, "/Render/Products/aux")
    aux.CreateProductNameAttr(aux_name)
    aux.CreateResolutionAttr(Gf.Vec2i(W // 2, H // 2))
    aux.CreateOrderedVarsRel().SetTargets([
        _var(stage, "depth", "depth"), _var(stage, "crypto", "CryptoObject"),
        _var(stage, "indirect", "C<RD>.*L", "lpe")])
    settings.CreateProductsRel().SetTargets([beauty.GetPath(), aux.GetPath()])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/rendersettings")
    stage.GetRootLayer().Export(str(path))
    return path


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    path = tmp_path_factory.mktemp("products") / "plane.usda"
    stage = _stage()
    stage.GetRootLayer().Export(str(path))
    return path


def _titles(names):
    return {f"ViewLayer.{table.PASSES[n].title}" for n in names}


def test_passes_all_writes_every_pass_under_blenders_names(plain, tmp_path):
    out = tmp_path / "all.exr"
    proc = lantern("render", plain, "-o", out, "--passes", "all", "--size", f"{W}x{H}")
    assert proc.returncode == 0, proc.stderr
    parts = read_parts(out)
    assert set(parts) == {"ViewLayer.Combined"} | _titles(p.name for p in table.provided())
    depth = parts["ViewLayer.Depth"][..., 0]
    centre = depth[H // 2 - 1:H // 2 + 1, W // 2 - 1:W // 2 + 1]
    print(f"Depth at the centre: {centre.mean():.6f} m (the plane is {DISTANCE} m away)")
    np.testing.assert_allclose(centre, DISTANCE, rtol=1e-5)
    normal = parts["ViewLayer.Normal"]
    drawn = depth < 1e9
    assert drawn.all()
    np.testing.assert_allclose(np.linalg.norm(normal[drawn], axis=-1), 1.0, atol=1e-5)
    import cryptomatte_reader as reader
    header, _ = reader.read(out)
    assert set(reader.matte_types(header)) == {
        "ViewLayer.CryptoObject", "ViewLayer.CryptoMaterial", "ViewLayer.CryptoAsset"}
    assert set(reader.matte_types(header)["ViewLayer.CryptoObject"]) == {"/root/plane",
                                                                         "/root/box"}


def test_passes_by_name_help_and_refusals(plain, tmp_path):
    out = tmp_path / "two.exr"
    proc = lantern("render", plain, "-o", out, "--passes", "depth,diffuse_direct",
                   "--size", "16x9")
    assert proc.returncode == 0, proc.stderr
    assert set(read_parts(out)) == {"ViewLayer.Combined", "ViewLayer.Depth",
                                    "ViewLayer.Diffuse Direct"}
    helped = lantern("render", "--passes", "help")
    assert helped.returncode == 0 and "crypto_object" in helped.stdout and \
        "Diffuse Direct.R/G/B" in helped.stdout
    for args, message in ((("--passes", "bogus", "-o", tmp_path / "x.exr"), "bogus"),
                          (("--passes", "depth", "-o", tmp_path / "x.png"), "need an .exr")):
        bad = lantern("render", plain, *args)
        assert bad.returncode == 2 and message in bad.stderr, bad.stderr
        assert len(bad.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.exr").exists() and not (tmp_path / "x.png").exists()


def _check_products(folder, frames=(1, 2, 3)):
    for frame in frames:
        beauty = read_parts(folder / f"beauty.{frame:04d}.exr")
        assert set(beauty) == {"ViewLayer.Combined"}
        assert beauty["ViewLayer.Combined"].shape == (H, W, 4)
        aux = read_parts(folder / "aux" / f"data.{frame:04d}.exr")
        assert set(aux) == {"ViewLayer.Combined"} | _titles(table.options()["crypto_object"]) \
            | {"ViewLayer.Depth"}
        assert all(a.shape[:2] == (H // 2, W // 2) for a in aux.values())


def test_products_name_the_files_of_a_sequence(tmp_path):
    """No -o: each product is a file named by its productName (relative to the working
    folder, $F4 the frame) at its own resolution; the RenderVar Lantern cannot make is
    one warning, and the rest are written."""
    stage = products_stage(tmp_path / "shot.usda")
    proc = lantern("render", stage, "--frames", "1:3", "-j", "1", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    _check_products(tmp_path)
    warnings = [line for line in proc.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "/Render/Vars/indirect" in warnings[0], proc.stderr
    assert not [n for n in os.listdir(tmp_path) if n.startswith(".")]


def test_the_farm_writes_the_same(tmp_path):
    stage = products_stage(tmp_path / "shot.usda")
    proc = lantern("render", stage, "--frames", "1:3", "--scheduler", "local", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    _check_products(tmp_path)


def _channels(path) -> list:
    """Each part's channel names, as a reader that looks for R, G, B, A sees them."""
    import OpenImageIO as oiio
    image = oiio.ImageInput.open(str(path))
    assert image is not None, oiio.geterror()
    parts, subimage = [], 0
    while image.seek_subimage(subimage, 0):
        parts.append(list(image.spec().channelnames))
        subimage += 1
    image.close()
    return parts


def _render_line(proc, path):
    lines = [line for line in proc.stdout.splitlines() if f"-> {path} (" in line]
    assert len(lines) == 1, proc.stdout
    return lines[0]


def depth_product_stage(path):
    """The exporter's layout for Blender's default view layer: one RenderProduct whose
    vars are Combined and Depth, the file Blender's Render Animation writes."""
    stage = _stage()
    settings = _settings(stage)
    product = UsdRender.Product.Define(stage, "/Render/Products/frames")
    product.CreateProductNameAttr("frames/shot_$F4.exr")
    product.CreateOrderedVarsRel().SetTargets([_var(stage, "color", "color"),
                                               _var(stage, "depth", "Depth")])
    settings.CreateProductsRel().SetTargets([product.GetPath()])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/rendersettings")
    stage.GetRootLayer().Export(str(path))
    return path


def test_o_is_the_plain_image_whatever_products_the_stage_names(tmp_path):
    """-o without --passes: one part, channels R, G, B, A, at the settings' size, and
    no product's file; the line printed says so."""
    stage = depth_product_stage(tmp_path / "shot.usda")
    out = tmp_path / "out.exr"
    proc = lantern("render", stage, "--frame", "2", "-o", out, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert _channels(out) == [["R", "G", "B", "A"]]
    from lantern.engine.image_io import read_exr
    assert read_exr(str(out)).shape == (H, W, 4)
    assert not (tmp_path / "frames").exists()
    assert f"(-o: {W}x{H}, plain RGBA," in _render_line(proc, out)


def test_without_o_the_products_are_rendered(tmp_path):
    """No -o: the product's file, named by its productName, holds Combined and Depth
    under Blender's layer names; the line printed names the RenderProduct."""
    stage = depth_product_stage(tmp_path / "shot.usda")
    proc = lantern("render", stage, "--frame", "2", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "frames" / "shot_0002.exr"
    assert _channels(out) == [[f"ViewLayer.Combined.{c}" for c in "RGBA"],
                              ["ViewLayer.Depth.Z"]]
    np.testing.assert_allclose(read_parts(out)["ViewLayer.Depth"][H // 2, W // 2], DISTANCE,
                               rtol=1e-5)
    line = _render_line(proc, out)
    assert f"(RenderProduct /Render/Products/frames: {W}x{H}, 1 pass," in line, line


def test_one_frame_of_two_products(tmp_path):
    """One frame: the tokens take the frame rendered. With -o, the one plain image and
    no product's file."""
    stage = products_stage(tmp_path / "shot.usda")
    proc = lantern("render", stage, "--frame", "2", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    _check_products(tmp_path, frames=(2,))
    proc = lantern("render", stage, "--frame", "3", "-o", tmp_path / "mine.exr", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert _channels(tmp_path / "mine.exr") == [["R", "G", "B", "A"]]
    assert not (tmp_path / "beauty.0003.exr").exists()
    assert not (tmp_path / "aux" / "data.0003.exr").exists()
    # A .gif preview is one output: with -o the products do not apply.
    gif = lantern("render", stage, "--frames", "1:2", "-o", tmp_path / "a.gif", cwd=tmp_path)
    assert gif.returncode == 0, gif.stderr
    assert (tmp_path / "a.gif").exists() and not (tmp_path / "beauty.0001.exr").exists()


def test_a_product_in_a_folder_that_cannot_be_written(tmp_path):
    (tmp_path / "blocker").write_text("a file, not a folder")
    stage = products_stage(tmp_path / "shot.usda", aux_name="blocker/data.$F4.exr")
    proc = lantern("render", stage, "--frame", "1", cwd=tmp_path)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    errors = [line for line in lines if not line.startswith("warning:")]
    assert len(errors) == 1 and "blocker" in errors[0], proc.stderr
    assert not (tmp_path / "beauty.0001.exr").exists()


def test_settings_picks_the_render_settings(tmp_path):
    """--settings names the RenderSettings prim; one that is not is exit 2."""
    stage = products_stage(tmp_path / "shot.usda")
    from pxr import Usd
    layer = Usd.Stage.Open(str(stage))
    other = UsdRender.Settings.Define(layer, "/Render/other")
    other.CreateResolutionAttr(Gf.Vec2i(20, 10))
    layer.GetRootLayer().Save()
    proc = lantern("render", stage, "--settings", "/Render/other", "-o", tmp_path / "o.exr")
    assert proc.returncode == 0, proc.stderr
    from lantern.engine.image_io import read_exr
    assert read_exr(str(tmp_path / "o.exr")).shape == (10, 20, 4)   # no products: -o, plain
    bad = lantern("render", stage, "--settings", "/root/cam", "-o", tmp_path / "b.exr")
    assert bad.returncode == 2 and "not a RenderSettings" in bad.stderr


def test_layers_are_written_to_a_temporary_name_then_renamed(tmp_path, monkeypatch):
    """A write that fails half way leaves neither the file nor its temporary."""
    from lantern.engine import image_io
    real = image_io._write_parts

    def fail_after_writing(path, *args):
        real(path, *args)
        raise OSError("disk full")

    monkeypatch.setattr(image_io, "_write_parts", fail_after_writing)
    rgba = np.zeros((4, 4, 4), np.float32)
    with pytest.raises(OSError):
        image_io.write_layers(str(tmp_path / "x.exr"), rgba,
                              {"Depth": np.ones((4, 4, 1), np.float32)})
    assert os.listdir(tmp_path) == []
