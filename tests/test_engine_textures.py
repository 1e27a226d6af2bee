"""Textured materials: a top-down plane lit by a sun of irradiance pi straight down,
so a white Lambert pixel reads exactly its albedo."""
import math

import imageio.v3 as iio
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from lantern.engine import RenderSettings, render_stage
from lantern.engine.bounces import Bounces

W, H = 80, 60
HALF = 2.0           # plane half size; the camera sees x in +-3.6, y in +-2.7


def srgb_to_linear(c):
    c = c / 255.0
    return ((c + 0.055) / 1.055) ** 2.4 if c > 0.04045 else c / 12.92


def textured_stage(tex_path, uv_range=(0.0, 1.0), wrap="repeat", colorspace="sRGB"):
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    mesh = UsdGeom.Mesh.Define(stage, "/root/plane/mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([(-HALF, -HALF, 0), (HALF, -HALF, 0), (HALF, HALF, 0), (-HALF, HALF, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    a, b = uv_range
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("UVMap", Sdf.ValueTypeNames.TexCoord2fArray,
                                                 UsdGeom.Tokens.faceVarying)
    pv.Set([(a, a), (b, a), (b, b), (a, b)])
    mat = UsdShade.Material.Define(stage, "/root/_materials/checker")
    surf = UsdShade.Shader.Define(stage, "/root/_materials/checker/surface")
    surf.CreateIdAttr("UsdPreviewSurface")
    surf.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    surf.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    surf.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((0.25, 0.5, 0.75))
    reader = UsdShade.Shader.Define(stage, "/root/_materials/checker/uv")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("UVMap")
    tex = UsdShade.Shader.Define(stage, "/root/_materials/checker/tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_path))
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(wrap)
    tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(wrap)
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(colorspace)
    surf.GetInput("diffuseColor").ConnectToSource(tex.ConnectableAPI(), "rgb")
    mat.CreateSurfaceOutput().ConnectToSource(surf.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateFocalLengthAttr(20.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(27.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100))
    cam.AddTranslateOp().Set((0, 0, 4))
    sun = UsdLux.DistantLight.Define(stage, "/root/sun")
    sun.CreateIntensityAttr(math.pi)
    return stage


def pixel_of(x, y):
    """Pixel (row, col) looking at plane point (x, y)."""
    col = (x / 4 * 20 / 18 + 1) / 2 * W
    row = (1 - y / 4 * 20 / 13.5) / 2 * H
    return int(row), int(col)


def uv_to_xy(u, v, uv_range=(0.0, 1.0)):
    a, b = uv_range
    return -HALF + (u - a) / (b - a) * 2 * HALF, -HALF + (v - a) / (b - a) * 2 * HALF


def test_checker_with_mips(tmp_path):
    n, cell = 64, 16
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    img = np.where(((ii // cell) + (jj // cell)) % 2 == 0, 255, 128).astype(np.uint8)
    path = tmp_path / "checker.png"
    iio.imwrite(path, np.stack([img] * 3, -1))
    res = render_stage(textured_stage(path), RenderSettings(width=W, height=H))
    assert not res.warnings
    # Texel centre of cell (0, 0) of the image (top-left) -> st (0.125, 0.875): white.
    white = res.rgba[pixel_of(*uv_to_xy(0.125, 0.875))]
    grey = res.rgba[pixel_of(*uv_to_xy(0.375, 0.875))]
    assert abs(white[0] - 1.0) < 0.02
    assert abs(grey[0] - srgb_to_linear(128)) < 0.02   # decoded from sRGB
    # A far-away, minified repeat still averages towards the mean (mips, no aliasing).
    far = render_stage(textured_stage(path, uv_range=(0.0, 40.0)), RenderSettings(width=W, height=H))
    r, c = pixel_of(0, 0)
    patch = far.rgba[r - 3:r + 3, c - 3:c + 3, 0]
    mean = (1.0 + srgb_to_linear(128)) / 2
    assert abs(patch.mean() - mean) < 0.05 and patch.std() < 0.05


def halves(tmp_path):
    img = np.zeros((32, 32, 3), np.uint8)
    img[:, :16] = 255          # left half white, right half black
    path = tmp_path / "halves.png"
    iio.imwrite(path, img)
    return path


def test_wrap_black_and_mirror(tmp_path):
    path = halves(tmp_path)
    rng = (-1.0, 2.0)
    sample = lambda res, u, v: res.rgba[pixel_of(*uv_to_xy(u, v, rng))][0]
    black = render_stage(textured_stage(path, rng, "black"), RenderSettings(width=W, height=H))
    assert sample(black, 0.25, 0.5) > 0.95              # inside [0, 1]: the image
    assert sample(black, 1.25, 0.5) < 0.01              # outside: black
    assert sample(black, -0.75, 0.5) < 0.01
    mirror = render_stage(textured_stage(path, rng, "mirror"), RenderSettings(width=W, height=H))
    repeat = render_stage(textured_stage(path, rng, "repeat"), RenderSettings(width=W, height=H))
    assert sample(mirror, 1.25, 0.5) < 0.05             # folded: u 0.75, the black half
    assert sample(repeat, 1.25, 0.5) > 0.95             # wrapped: u 0.25, the white half
    assert sample(mirror, -0.25, 0.5) > 0.95            # folded: u 0.25
    clamp = render_stage(textured_stage(path, rng, "clamp"), RenderSettings(width=W, height=H))
    assert sample(clamp, -0.75, 0.5) > 0.95 and sample(clamp, 1.75, 0.5) < 0.05


def test_missing_texture_warns_and_falls_back(tmp_path):
    res = render_stage(textured_stage(tmp_path / "nope.png"), RenderSettings(width=W, height=H))
    assert any("/root/_materials/checker" in w and "nope.png" in w for w in res.warnings), res.warnings
    px = res.rgba[pixel_of(0, 0)]
    assert np.allclose(px[:3], (0.25, 0.5, 0.75), atol=0.01)


def normal_mapped_stage(tmp_path, rgb):
    """The plane with its constant colour and a normal map of one texel `rgb` (8-bit,
    n = 2c - 1 in the tangent frame)."""
    path = tmp_path / f"n{rgb[0]}.png"
    iio.imwrite(path, np.full((8, 8, 3), rgb, np.uint8))
    stage = textured_stage(tmp_path / "missing.png")
    surf = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/checker/surface"))
    surf.GetInput("diffuseColor").ClearSources()
    nt = UsdShade.Shader.Define(stage, "/root/_materials/checker/normal")
    nt.CreateIdAttr("UsdUVTexture")
    nt.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(path))
    nt.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    nt.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set((2, 2, 2, 1))
    nt.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set((-1, -1, -1, 0))
    reader = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/checker/uv"))
    nt.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    surf.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(nt.ConnectableAPI(), "rgb")
    return stage


def test_flat_normal_map_changes_nothing_tilted_one_does(tmp_path):
    def with_normal_map(rgb):
        stage = normal_mapped_stage(tmp_path, rgb)
        return render_stage(stage, RenderSettings(width=W, height=H)).rgba[pixel_of(0, 0)]

    flat = with_normal_map((128, 128, 255))
    assert np.allclose(flat[:3], (0.25, 0.5, 0.75), rtol=0.02)
    # 45 degrees about the tangent: cos 45 of the overhead sun.
    tilted = with_normal_map((255, 128, 255))
    assert np.allclose(tilted[:3], np.array((0.25, 0.5, 0.75)) * math.cos(math.pi / 4), rtol=0.03)


def test_dome_lat_long_map(tmp_path):
    from lantern.engine import write_image
    path = tmp_path / "sky.exr"
    write_image(str(path), np.ones((16, 32, 4), np.float32))
    stage = textured_stage(tmp_path / "missing.png")
    stage.RemovePrim("/root/sun")
    dome = UsdLux.DomeLight.Define(stage, "/root/_world")
    dome.CreateIntensityAttr(0.5)
    dome.CreateTextureFileAttr(str(path))
    res = render_stage(stage, RenderSettings(width=W, height=H))
    assert not [w for w in res.warnings if "_world" in w]
    # A uniform sky of radiance L: a Lambert plane reflects albedo * L; background L.
    assert np.allclose(res.rgba[pixel_of(0, 0)][:3], np.array((0.25, 0.5, 0.75)) * 0.5, rtol=0.02)
    assert np.allclose(res.rgba[0, 0, :3], 0.5, rtol=1e-3)
    dome.CreateTextureFileAttr(str(tmp_path / "gone.exr"))
    res = render_stage(stage, RenderSettings(width=W, height=H))
    assert any("/root/_world" in w and "gone.exr" in w for w in res.warnings)


def test_a_half_metal_is_half_of_each_lobe(tmp_path):
    """Cycles' Principled BSDF blends its dielectric and metal lobes by Metallic, each
    with its own multiple-scattering energy: metallic 0.5 lights as the mean of 0 and 1
    (one energy factor for the blended F0 made it 13% darker at roughness 1)."""
    def lit(metallic):
        stage = textured_stage(tmp_path / "missing.png")
        surf = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/checker/surface"))
        surf.GetInput("diffuseColor").ClearSources()
        surf.GetInput("diffuseColor").Set((0.9, 0.7, 0.3))
        surf.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(metallic)
        return render_stage(stage, RenderSettings(width=W, height=H)).rgba[pixel_of(0, 0)][:3]
    half, ends = lit(0.5), (lit(0.0) + lit(1.0)) / 2
    print(f"metallic 0.5: {half.round(4)}, mean of 0 and 1: {ends.round(4)}")
    assert np.allclose(half, ends, rtol=1e-3)


def test_a_rough_white_metal_reflects_the_sun_as_its_lobe_with_1_over_e(tmp_path):
    """Roughness 1, light and view along the normal: the GGX lobe gives F D G/(4 cos
    cos) = 1/(4 pi), times the sun's irradiance pi, times the energy factor 1/E(1, 1)
    (Cycles' preserve_energy) = 0.25 / 0.307. The split-sum table is read at n.v and
    roughness 1 themselves (it was clamped half a texel short: 0.766 for 0.815)."""
    from lantern.engine.lighting import dfg_terms
    stage = textured_stage(tmp_path / "missing.png")
    surf = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/checker/surface"))
    surf.GetInput("diffuseColor").ClearSources()
    surf.GetInput("diffuseColor").Set((1.0, 1.0, 1.0))
    surf.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(1.0)
    e = float(dfg_terms(np.array([1.0]), np.array([1.0]), samples=1 << 16)[0, 1])
    # The camera looks straight down at the plate's centre.
    got = render_stage(stage, RenderSettings(width=W, height=H)).rgba[pixel_of(0, 0)][:3]
    print(f"white metal, roughness 1: {got.round(4)}, closed form {0.25 / e:.4f}")
    assert np.allclose(got, 0.25 / e, rtol=0.01)


def test_an_srgb_image_is_interpolated_in_its_stored_values_exactly(tmp_path):
    """Cycles interpolates an 8-bit sRGB image in the values it stores, then decodes.
    The shader gets GL's decoding of each texel and recovers the stored value
    (material.glsl stored_value); a block of one value reads its exact decoding, for
    every one of the 256 values, within two of the G-buffer's float16 steps. llvmpipe's
    own decoding is a curve fit: encoding it again with pow was off by up to 2.5%."""
    blocks, side = 16, 4                       # 16 x 16 blocks of 4 x 4 texels
    values = np.arange(256, dtype=np.uint8).reshape(blocks, blocks)
    img = np.repeat(np.repeat(values, side, 0), side, 1)
    path = tmp_path / "bytes.png"
    iio.imwrite(path, np.stack([img] * 3, -1))
    w, h = 4 * W, 4 * H                        # 2.75 pixels a texel, 11 a block
    res = render_stage(textured_stage(path), RenderSettings(width=w, height=h))
    assert not res.warnings
    got, want = [], []
    for (i, j), value in np.ndenumerate(values):
        u, v = (j + 0.5) / blocks, 1 - (i + 0.5) / blocks     # the block's centre
        row, col = pixel_of(*uv_to_xy(u, v))
        got.append(res.rgba[row * 4 + 2, col * 4 + 2, 0])
        want.append(srgb_to_linear(float(value)))
    got, want = np.array(got, np.float64), np.array(want)
    error = np.abs(got - want) / np.maximum(want, 1e-3)
    print(f"largest relative error {error.max():.2e} at value {error.argmax()}")
    assert error.max() < 2.0 ** -9


def _levels_read_back(gl, tex, sizes):
    """Each level of an RGBA8 texture as GL holds it (glGetTexImage: ModernGL reads
    only levels it generated)."""
    import ctypes
    from lantern.engine.gpu.stencil import entry_points
    u = ctypes.c_uint
    fn = entry_points(gl.proc, {"glActiveTexture": (None, u), "glBindTexture": (None, u, u),
                                "glGetTexImage": (None, u, ctypes.c_int, u, u, ctypes.c_void_p)})
    fn["glActiveTexture"](0x84C0 + gl.ctx.default_texture_unit)
    fn["glBindTexture"](0x0DE1, tex.glo)
    levels = []
    for level, (w, h) in enumerate(sizes):
        out = np.zeros((h, w, 4), np.uint8)
        fn["glGetTexImage"](0x0DE1, level, 0x1908, 0x1401, out.ctypes.data)
        levels.append(out)
    return levels


def test_mip_levels_of_8_bit_images_are_written_as_computed(tmp_path):
    """An 8-bit image's mip chain goes up as computed (the driver generates no level:
    llvmpipe builds a blit shader for that in every new process); data mips from
    power-of-two sizes are the bytes llvmpipe's glGenerateMipmap made."""
    from lantern.engine.gpu.context import run_gl
    from lantern.engine.gpu.resources import Uploads
    from lantern.engine.gpu.textures import data_mips

    def check(gl):
        rng = np.random.default_rng(7)
        for w, h in ((64, 32), (8, 1), (6, 10), (5, 7)):
            img = rng.integers(0, 256, (h, w, 4), dtype=np.uint8)
            levels = data_mips(img)
            sizes = [(lv.shape[1], lv.shape[0]) for lv in levels]
            assert sizes[-1] == (1, 1) and all(s == (max(w >> i, 1), max(h >> i, 1))
                                               for i, s in enumerate(sizes))
            tex = Uploads(gl.ctx, gl.proc).mipmapped_texture(levels, kind="textures")
            for given, held in zip(levels, _levels_read_back(gl, tex, sizes)):
                assert np.array_equal(given, held)
            tex.release()
            if "llvmpipe" in gl.ctx.info["GL_RENDERER"] and w & (w - 1) == 0 and h & (h - 1) == 0:
                generated = gl.ctx.texture((w, h), 4, img.tobytes())
                generated.build_mipmaps()
                for given, made in zip(levels, _levels_read_back(gl, generated, sizes)):
                    assert np.array_equal(given, made)
                generated.release()
    run_gl(check)


def test_a_textured_render_generates_no_mips_in_the_driver(tmp_path, monkeypatch):
    """8-bit colour and 8-bit data: their mips come from the CPU (a cold render's first
    frame compiled llvmpipe's mipmap blit, 0.1-0.15 s a format); far away they still
    average."""
    import moderngl
    generated = []
    build = moderngl.Texture.build_mipmaps
    monkeypatch.setattr(moderngl.Texture, "build_mipmaps",
                        lambda self, *a, **k: (generated.append(self), build(self, *a, **k)))
    n, cell = 64, 16
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    img = np.where(((ii // cell) + (jj // cell)) % 2 == 0, 255, 128).astype(np.uint8)
    path = tmp_path / "checker.png"
    iio.imwrite(path, np.stack([img] * 3, -1))
    for colorspace, mean in (("sRGB", (1.0 + srgb_to_linear(128)) / 2), ("raw", 383 / 510)):
        far = render_stage(textured_stage(path, uv_range=(0.0, 40.0), colorspace=colorspace),
                           RenderSettings(width=W, height=H))
        r, c = pixel_of(0, 0)
        patch = far.rgba[r - 3:r + 3, c - 3:c + 3, 0]
        assert abs(patch.mean() - mean) < 0.05 and patch.std() < 0.05, colorspace
    assert generated == []


def test_an_images_mean_is_taken_from_its_pixels_once(tmp_path, monkeypatch):
    """The irradiance field asks for a textured material's mean linear colour: for an
    8-bit image it comes from the histogram, equal to the mean of the decoded texels,
    and a render with bounces reads the file once, for the upload and the mean."""
    from lantern.engine import textures
    from lantern.engine.gpu import textures as gpu_textures
    img = np.random.default_rng(5).integers(0, 256, (37, 29, 4), dtype=np.uint8)
    for colorspace in ("auto", "raw", "sRGB"):
        want = textures.linear(img, colorspace).reshape(-1, 4).mean(axis=0, dtype=np.float64)
        np.testing.assert_allclose(textures.linear_mean(img, colorspace), want,
                                   rtol=0, atol=1e-12)
    path = tmp_path / "noise.png"
    iio.imwrite(path, img[..., :3])
    reads = []
    real = gpu_textures.read_rgba
    monkeypatch.setattr(gpu_textures, "read_rgba", lambda p: reads.append(p) or real(p))
    stage = textured_stage(path)
    cube = UsdGeom.Cube.Define(stage, "/root/cube")        # a surface the plane lights
    cube.AddTranslateOp().Set((0.0, 0.0, 0.5))
    cube.CreateSizeAttr(1.0)
    UsdShade.MaterialBindingAPI.Apply(cube.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath("/root/_materials/checker")))
    result = render_stage(stage, RenderSettings(width=W, height=H, bounces=Bounces()))
    assert result.stats["field_probes"] > 0 and reads == [str(path)]
