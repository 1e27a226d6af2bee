"""The shading (docs/rendering.md) against independent answers: the split-sum table
against brute-force integration, the dome's harmonics against a function they hold
exactly, a uniform world's exact hemisphere term, clearcoat read from USD, the sRGB
mip chain, supersampling's GPU filter against the same filter in numpy and its edge
samples against a straight edge filtered exactly, the post chain's operations, and the
lighting render passes adding up to the image."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

import shadow_scenes as ss
from lantern.engine import RenderSettings, render_stage
from test_shadows import top_down_camera


# --- the split-sum table ----------------------------------------------------------------

def brute_force_albedo(nov, roughness, f0, n=400):
    """Directional albedo of the Schlick-GGX lobe (height-correlated Smith), single
    scattering, by midpoint integration over the hemisphere (no importance sampling)."""
    a = max(roughness * roughness, 2e-3)
    theta = (np.arange(n) + 0.5) / n * math.pi / 2
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * math.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    l = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    v = np.array([math.sqrt(1 - nov * nov), 0.0, nov])
    h = l + v
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    nol, noh, voh = l[..., 2], h[..., 2], h @ v
    d = a * a / (math.pi * (noh * noh * (a * a - 1) + 1) ** 2)
    gv = nol * np.sqrt(nov * nov * (1 - a * a) + a * a)
    gl = nov * np.sqrt(nol * nol * (1 - a * a) + a * a)
    f = f0 + (1 - f0) * (1 - voh) ** 5
    integrand = d * (0.5 / (gv + gl)) * f * nol * np.sin(t)
    return float(integrand.sum() * (math.pi / 2 / n) * (2 * math.pi / (2 * n)))


@pytest.mark.parametrize("nov, roughness", [(0.9, 0.3), (0.5, 0.5), (0.3, 0.8), (0.7, 1.0)])
def test_dfg_table_matches_brute_force_integration(nov, roughness):
    from lantern.engine.lighting import dfg_terms
    x, y = dfg_terms(nov, roughness)
    for f0 in (0.04, 1.0):
        want = brute_force_albedo(nov, roughness, f0)
        got = f0 * (y - x) + x
        assert abs(got - want) <= 0.01 * want + 1e-3, (f0, got, want)


@pytest.mark.parametrize("name", ["dfg_lut", "velvet_albedo"])
def test_stored_tables_are_the_computed_ones(name, tmp_path, monkeypatch):
    """shaders/tables/ holds what engine/lighting.py computes (make_tables.py writes
    them); a missing or foreign file is computed instead."""
    from lantern.engine import lighting
    compute = {"dfg_lut": lighting.compute_dfg_lut,
               "velvet_albedo": lighting.compute_velvet_albedo_lut}[name]
    want = compute()
    assert np.array_equal(lighting._stored(name, lambda: None), want)
    monkeypatch.setattr(lighting, "TABLES", str(tmp_path))
    assert np.array_equal(lighting._stored(name, compute), want)          # missing
    np.save(tmp_path / f"{name}.npy", np.zeros((2, 2), np.float32))
    assert np.array_equal(lighting._stored(name, compute), want)          # foreign


def test_the_velvet_albedo_integrates_cycles_velvet():
    """The velvet table's integral against a finer one, and a grazing view's albedo
    near 1 (the velvet lobe sends grazing light back), within 0.02."""
    from lantern.engine.lighting import compute_velvet_albedo_lut
    coarse, fine = compute_velvet_albedo_lut(), compute_velvet_albedo_lut(steps=192)
    assert np.abs(coarse - fine).max() < 0.02
    assert 0.9 < coarse[8, 0, 0] < 1.05


def test_multiple_scattering_restores_a_white_metal():
    """A white furnace: f0 = 1 reflects everything at any roughness once the energy
    factor is applied (Kulla-Conty as Filament uses it)."""
    from lantern.engine.lighting import specular_albedo
    for r in (0.0, 0.5, 1.0):
        assert specular_albedo(1.0, 1.0, 0.6, r) == pytest.approx(1.0, abs=1e-6)


# --- the dome ---------------------------------------------------------------------------

def test_harmonics_of_a_linear_sky_are_exact():
    """L(d) = 1 + d.y lies in the first two bands: irradiance pi + (2 pi / 3) n.y."""
    from lantern.engine.lighting import latlong_dirs, latlong_sh, sh_basis, uniform_sh
    d, _ = latlong_dirs(64, 128)
    img = (1.0 + d[..., 1:2]) * np.ones(3)
    sh = latlong_sh(img)
    for n in (np.array([0, 1.0, 0]), np.array([0, -1.0, 0]), np.array([0.6, 0.0, 0.8])):
        assert sh_basis(n) @ sh[:, 0] == pytest.approx(math.pi + 2 * math.pi / 3 * n[1], rel=2e-3)
    # A uniform map: the constant term exactly (each texel's true solid angle), the
    # others at the quadrature's 1e-3 of it.
    flat = latlong_sh(np.ones((32, 64, 3)))
    assert flat[0] == pytest.approx(uniform_sh(np.ones(3))[0], rel=1e-9)
    assert np.abs(flat[1:]).max() < 1e-3 * flat[0, 0]


def uniform_dome_stage(radiance, albedo):
    stage = ss.new_stage()
    mat = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/white/surface"))
    mat.GetInput("diffuseColor").Set(Gf.Vec3f(albedo, albedo, albedo))
    dome = UsdLux.DomeLight.Define(stage, "/root/dome")
    dome.CreateIntensityAttr(radiance)
    top_down_camera(stage, 8.0)
    return stage


def test_a_uniform_world_gives_the_hemisphere_term_exactly():
    """A Lambert plane of albedo 0.5 under a uniform dome of radiance 2 reflects
    0.5 x 2 (irradiance pi x 2, over pi), with nothing to occlude it."""
    r = render_stage(uniform_dome_stage(2.0, 0.5), RenderSettings(width=32, height=32))
    assert np.allclose(r.rgba[..., :3], 1.0, rtol=2e-3)


# --- materials --------------------------------------------------------------------------

def test_clearcoat_is_read_from_usd_preview_surface():
    from lantern.engine.usd.materials import read_material
    stage, other = ss.new_stage(), ss.new_stage()
    sh = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/white/surface"))
    sh.CreateInput("clearcoat", Sdf.ValueTypeNames.Float).Set(0.75)
    sh.CreateInput("clearcoatRoughness", Sdf.ValueTypeNames.Float).Set(0.2)
    mat = read_material(UsdShade.Material(stage.GetPrimAtPath("/root/_materials/white")), 0, [])
    assert (mat.clearcoat, mat.clearcoat_roughness) == pytest.approx((0.75, 0.2))
    bare = read_material(UsdShade.Material(other.GetPrimAtPath("/root/_materials/white")), 0, [])
    assert (bare.clearcoat, bare.clearcoat_roughness) == (0.0, 0.01)   # the schema's defaults


def test_a_coat_adds_a_white_lobe_and_takes_from_the_base():
    """Under a uniform white dome a coated grey plane: the coat reflects more at
    grazing angles (brighter there than the uncoated plane) while at normal incidence
    it takes from the base about what it reflects (within 1 %)."""
    def plane(coat):
        stage = uniform_dome_stage(1.0, 0.5)
        sh = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/white/surface"))
        sh.CreateInput("clearcoat", Sdf.ValueTypeNames.Float).Set(coat)
        return render_stage(stage, RenderSettings(width=16, height=16, ambient_occlusion=False))
    bare, coated = plane(0.0).rgba[8, 8, 0], plane(1.0).rgba[8, 8, 0]
    # Straight down: coat albedo ~0.04, base 0.5 -> 0.04 + 0.96 * 0.5 = 0.52.
    assert coated == pytest.approx(0.04 + 0.96 * 0.5, abs=0.01) and coated > bare


# --- textures ---------------------------------------------------------------------------

def test_srgb_mip_chain_averages_cycles_lookups_in_linear_light():
    """A 0/255 two-texel image: its level-1 texel is the mean of Cycles' lookups
    (bilinear of the bytes, then decoded) over it, not decode(mean byte)."""
    from lantern.engine.color import linear_to_srgb
    from lantern.engine.gpu.textures import cycles_srgb_mips
    from lantern.engine.textures import srgb_to_linear
    img = np.zeros((2, 2, 4), np.uint8)
    img[:, 1, :3] = 255
    img[..., 3] = 255
    level1 = cycles_srgb_mips(img)[1]
    # Lookups at x = 0.25, 0.75, 1.25, 1.75: bytes 0, 0.25, 0.75, 1 (edges repeat).
    expected = np.mean([0.0, srgb_to_linear(0.25), srgb_to_linear(0.75), 1.0])
    assert level1.shape == (1, 1, 4)
    assert level1[0, 0, 0] == round(float(linear_to_srgb(expected)) * 255)
    assert level1[0, 0, 0] != 188            # what averaging in linear light alone gives


@pytest.mark.parametrize("shape", [(5, 7), (1, 6), (6, 1), (2, 2), (300, 3)])
def test_srgb_mip_level1_is_the_mean_of_cycles_lookups_over_each_texel(shape):
    """Level 1 (before its encoding), lookup by lookup: Cycles' bilinear of the bytes
    at +-1/4 texel about each level-0 texel's centre (edges repeat), decoded, averaged
    over the level-1 texel's 2 x 2 level-0 texels (one across a side one texel thin;
    an odd last row or column left out), alpha not decoded. In bands of rows (the
    300-row case spans two)."""
    from lantern.engine.gpu import textures
    from lantern.engine.textures import srgb_to_linear
    img = np.random.default_rng(3).integers(0, 256, shape + (4,), dtype=np.uint8)
    h, w = shape
    e = img.astype(np.float64) / 255.0

    def lookup(y, x):                   # texel units, texel centres at integers
        y0, x0 = int(np.floor(y)), int(np.floor(x))
        fy, fx = y - y0, x - x0
        at = lambda r, c: e[min(max(r, 0), h - 1), min(max(c, 0), w - 1)]
        v = ((1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
             fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1)))
        return np.r_[srgb_to_linear(v[:3]), v[3]]

    ry, rx = (2 if h > 1 else 1), (2 if w > 1 else 1)
    want = np.array([[np.mean([lookup(ry * i + a + dy, rx * j + b + dx)
                               for a in range(ry) for b in range(rx)
                               for dy in (-0.25, 0.25) for dx in (-0.25, 0.25)], axis=0)
                      for j in range(max(w // 2, 1))] for i in range(max(h // 2, 1))])
    got = np.concatenate([textures._level1_band(img, r0, min(r0 + 128, len(want)), len(want[0]))
                          for r0 in range(0, len(want), 128)])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert (textures.cycles_srgb_mips(img)[1] == textures.to_srgb8(want)).all()


# --- anti-aliasing ----------------------------------------------------------------------

def box_stage():
    stage = ss.new_stage()
    ss.add_box(stage, center=(0.3, 0.2, 0.5))
    ss.add_light(stage, "sun", shadow=True, dir=(1.0, 0.6, -1.0))
    ss.add_camera(stage, eye=(4.0, -5.0, 3.5), target=(0.0, 0.0, 0.4))
    return stage


def test_supersampling_filters_as_the_numpy_filter():
    """The GPU's down-sample of a 2x image equals Cycles' filter applied in numpy to
    the same 2x image (float16 light: 1e-3 relative)."""
    from image_metrics import downsample
    stage = box_stage()
    big = render_stage(stage, RenderSettings(width=96, height=54, supersample=1, fxaa=False)).rgba
    small = render_stage(stage, RenderSettings(width=48, height=27, supersample=2)).rgba
    assert np.allclose(small[..., :3], downsample(big[..., :3], 2), rtol=2e-3, atol=2e-4)


def edge_stage(n, width_m, edge_col, edge_row):
    """A white plane lit straight down (radiance 1), seen top-down (tests/test_shadows.py
    top_down_camera) on an n x n image: it covers the image left of column `edge_col`
    and below row `edge_row` (pixels from the left and the top), its edges along the
    rows and columns."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    xe, ye = (edge_col / n - 0.5) * width_m, (0.5 - edge_row / n) * width_m
    mesh = UsdGeom.Mesh.Define(stage, "/root/plane")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([(-10, -10, 0), (xe, -10, 0), (xe, ye, 0), (-10, ye, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(ss.white_material(stage))
    ss.add_light(stage, "sun", shadow=False, strength=math.pi)
    top_down_camera(stage, width_m)
    return stage


def covered(t):
    """The share of Cycles' pixel filter, centred t pixels inside a straight edge, that
    the covered side holds."""
    from lantern.engine.gpu.passes.antialias import FILTER_WIDTH, blackman_harris
    x = np.linspace(-FILTER_WIDTH, FILTER_WIDTH, 20001)
    w = blackman_harris(x)
    return float(np.trapz(w * (x < t), x) / np.trapz(w, x))


def test_edge_samples_put_an_edge_along_the_rows_where_it_lies():
    """At high (2x2 sub-pixels and their edge samples: passes/antialias.py) a plane's
    edges, along a column and along a row, a quarter of a pixel from the nearest line
    between sub-pixel centres, filter as Cycles' pixel filter filters a straight edge
    where it lies: within 3% of the plane's light at every pixel (measured: 1.9% and
    0.6%). The sub-pixels alone put each edge on that line, 21% and 17% off."""
    n, edge_col, edge_row = 32, 20.26, 11.76
    image = render_stage(edge_stage(n, 3.2, edge_col, edge_row),
                         RenderSettings(width=n, height=n, preset="high")).rgba[..., 0]
    assert image[28, 4] == pytest.approx(1.0, abs=1e-3)
    across_column = [covered(edge_col - (i + 0.5)) for i in range(n)]
    across_row = [covered((r + 0.5) - edge_row) for r in range(n)]
    worst = max(np.abs(image[28] - across_column).max(), np.abs(image[:, 4] - across_row).max())
    print(f"largest error across the edges: {worst:.4f}")
    assert worst <= 0.03


# --- post -------------------------------------------------------------------------------

def test_post_operations():
    stage = box_stage()
    base = dict(width=48, height=27, fxaa=False)
    plain = render_stage(stage, RenderSettings(**base)).rgba
    mirrored = render_stage(stage, RenderSettings(**base, mirror="x")).rgba
    assert np.array_equal(mirrored, plain[:, ::-1])
    flipped = render_stage(stage, RenderSettings(**base, mirror="xy")).rgba
    assert np.array_equal(flipped, plain[::-1, ::-1])
    grey = render_stage(stage, RenderSettings(**base, grayscale=True)).rgba
    luma = plain[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    assert np.allclose(grey[..., 0], luma, rtol=2e-3) and np.array_equal(grey[..., 0], grey[..., 2])
    brighter = render_stage(stage, RenderSettings(**base, exposure=1.0)).rgba
    assert np.allclose(brighter[..., :3], 2 * plain[..., :3], rtol=2e-3)
    blurred = render_stage(stage, RenderSettings(**base, blur=2.0)).rgba
    assert blurred[..., :3].std() < 0.9 * plain[..., :3].std()
    assert blurred[..., :3].mean() == pytest.approx(plain[..., :3].mean(), rel=0.03)


@pytest.mark.parametrize("bad", [dict(mirror="z"), dict(blur=-1.0), dict(supersample=0),
                                 dict(srgb_filtering="gamma"), dict(exposure=float("nan"))])
def test_bad_settings_are_refused(bad):
    with pytest.raises(ValueError):
        RenderSettings(**bad)


# --- lighting render passes -------------------------------------------------------------

@pytest.mark.parametrize("preset", ["medium", "high"])
def test_lighting_passes_add_up_to_the_image(preset):
    """Also at high, where the light passes are reduced as the image is, edge samples
    included (passes/antialias.py SupersamplePass)."""
    stage = box_stage()
    UsdLux.DomeLight.Define(stage, "/root/dome").CreateIntensityAttr(0.3)
    names = ["DiffDir", "GlossDir", "Env", "Emit", "Shadow", "AO"]
    r = render_stage(stage, RenderSettings(width=64, height=36, fxaa=False, preset=preset,
                                           passes=frozenset(names)))
    total = sum(r.passes[n] for n in ("DiffDir", "GlossDir", "Env", "Emit"))
    assert np.allclose(total, r.rgba[..., :3], rtol=2e-3, atol=1e-4)
    shadow, ao = r.passes["Shadow"], r.passes["AO"]
    assert shadow.min() == 0.0 and shadow.max() == 1.0 and (shadow[..., 0] < 0.5).sum() > 10
    # Filtered in float32 on the GPU, as the image is: 1 within its rounding.
    assert 0.0 < ao.min() < 0.8 and abs(ao.max() - 1.0) < 1e-6
    # Asking for them changes nothing in the image.
    plain = render_stage(stage, RenderSettings(width=64, height=36, fxaa=False,
                                               preset=preset)).rgba
    assert np.array_equal(plain, r.rgba)
