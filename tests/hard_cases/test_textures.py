"""Textures: what an image holds reaches the pixels. The texture work (image reading on
OpenImageIO, texture formats, the G-buffer's range) makes these hold; the cases that
fail before it are marked for it.

- A 16-bit PNG emission gradient below 8-bit resolution (linear, raw) renders its
  16-bit values: error <= 1e-4 (8-bit reading is off by up to 1/510).
- A float EXR emission map (values 0.001 .. 100) renders its values: relative <= 1e-3.
- A float EXR base colour above 1, and a constant diffuseColor of 2, reflect twice
  what a base colour of 1 does (not clamped): relative <= 1e-3.
Every image is finite."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdLux, UsdShade

from lantern.engine import RenderSettings, render_stage

from hard_cases import engine_scenes as E  # tests/ is on sys.path (conftest.py)
from hard_cases.malformed_usd import write_png
S = E.S
W, H = 64, 36


def _textured_card(path, input_name, colorspace="raw", diffuse=(0, 0, 0), lit=False):
    """A card filling the view, its `input_name` read from the image at `path` (a
    black diffuse: only emission shows), no light (a dark dome), or a sun."""
    stage = S.new_stage(half=0.01)
    mat = UsdShade.Material.Define(stage, "/root/_materials/card")
    sh = UsdShade.Shader.Define(stage, "/root/_materials/card/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*diffuse))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    reader = UsdShade.Shader.Define(stage, "/root/_materials/card/st")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    tex = UsdShade.Shader.Define(stage, "/root/_materials/card/tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(path))
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(colorspace)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    sh.CreateInput(input_name, Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    card = E.quad(stage, "/root/card", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], mat,
                  (0, 0, 1))
    from pxr import UsdGeom
    st = UsdGeom.PrimvarsAPI(card).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                  UsdGeom.Tokens.vertex)
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    if lit:
        S.add_light(stage, "sun", strength=np.pi, dir=(0, 0, -1), shadow=False)
    else:
        UsdLux.DomeLight.Define(stage, "/root/dark").CreateIntensityAttr(0.0)
    # An orthographic camera looking straight down at the card: pixel (i, j) shows the
    # texel at the same place.
    cam = E.camera(stage, "/root/cam", (0, 0, 5), (0, 0, 0), 0.1, 10.0, up=(0, 1, 0))
    from pxr import UsdGeom as G
    cam.CreateProjectionAttr(G.Tokens.orthographic)
    cam.CreateHorizontalApertureAttr(20.0)
    cam.CreateVerticalApertureAttr(20.0 * H / W)
    return stage


def _render(stage):
    result = render_stage(stage, RenderSettings(width=W, height=H))
    assert np.isfinite(result.rgba).all() and result.stats["nonfinite_pixels"] == 0
    assert not result.warnings, result.warnings
    return result.rgba


def test_16_bit_png_precision(tmp_path, hard_case):
    # 16 blocks of 4 texels, 0 .. 0.06 in 16-bit steps (8-bit holds 16 levels there),
    # each read at a middle pixel.
    levels = (np.linspace(0.001, 0.06, 16) * 65535).round().astype(np.uint16)
    img = np.repeat(np.repeat(np.repeat(levels, 4)[None, :, None], 4, 0), 3, 2)
    path = tmp_path / "ramp16.png"
    write_png(path, img, bits=16)
    out = _render(_textured_card(path, "emissiveColor"))
    got = out[H // 2, 1::4, 0]
    want = levels.astype(np.float64) / 65535
    hard_case("16-bit PNG emission ramp (0..0.06, linear): rendered vs 16-bit values, max abs",
              float(np.abs(got - want).max()), 1e-4)


def test_float_exr_emission_keeps_its_values(tmp_path, hard_case):
    from lantern.engine.image_io import write_image
    # Eight blocks of 8 texels, 1e-3 .. 100; each block read at its middle pixels (away
    # from where filtering blends neighbours).
    values = np.geomspace(1e-3, 100.0, 8)
    img = np.ones((8, W, 4), np.float32)
    img[..., :3] = np.repeat(values, 8)[None, :, None]
    path = tmp_path / "emit.exr"
    write_image(str(path), img)
    out = _render(_textured_card(path, "emissiveColor"))
    got = out[H // 2, 3::8, 0]
    hard_case("float EXR emission 1e-3..100: rendered vs texel, relative",
              float((np.abs(got - values) / values).max()), 1e-3)


def test_float_exr_base_colour_above_one_is_not_clamped(tmp_path, hard_case):
    from lantern.engine.image_io import write_image
    img = np.full((8, 8, 4), 2.0, np.float32)
    img[..., 3] = 1.0
    path = tmp_path / "base.exr"
    write_image(str(path), img)
    out = _render(_textured_card(path, "diffuseColor", lit=True))
    # A sun of irradiance pi straight down on a Lambert surface: radiance = base colour.
    hard_case("float EXR base colour 2 under a sun: rendered / 2, relative error",
              float(np.abs(out[..., :3] / 2.0 - 1.0).max()), 1e-3)


def test_constant_base_colour_above_one_is_not_clamped(tmp_path, hard_case):
    from lantern.engine.image_io import write_image
    white = np.ones((2, 2, 4), np.float32)
    path = tmp_path / "white.exr"
    write_image(str(path), white)
    stage = _textured_card(path, "emissiveColor", diffuse=(2.0, 2.0, 2.0), lit=True)
    # No emission (a black map), a constant diffuse of 2.
    UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/card/surface")).GetInput(
        "emissiveColor").GetAttr().ClearConnections()
    out = _render(stage)
    hard_case("constant diffuseColor 2 under a sun: rendered / 2, relative error",
              float(np.abs(out[..., :3] / 2.0 - 1.0).max()), 1e-3)
