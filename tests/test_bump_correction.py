"""Cycles' bump map correction (Material > Settings > Bump Map Correction, on by default),
as shaders/lib.glsl has it: a plane whose normal map tilts every normal 45 degrees
towards +x (the tangent), lit by a sun or a uniform dome, against the same material
with `lantern:bumpMapCorrection = false`. The diffuse light's ratio between the two is
the correction's closed form: GGX's Smith G1 at alpha^2 = tan^2(bend) / 8, taken at the
light's angle to the smooth normal, and 0 for light from behind the smooth surface."""
import math
import pathlib
import re

import numpy as np
import pytest
from pxr import Sdf, UsdLux

from lantern.engine import RenderSettings, render_stage
from test_engine_textures import H, W, normal_mapped_stage, pixel_of, textured_stage

LIB = pathlib.Path(__file__).resolve().parent.parent / "shaders" / "lib.glsl"
BEND = math.radians(45.0)


def tilted_plane(tmp_path, correction: bool):
    """The plane of test_engine_textures, its diffuse colour constant, no specular
    (IOR 1), and a normal map of one texel tilting the normal 45 degrees to +x."""
    stage = normal_mapped_stage(tmp_path, (255, 128, 255))
    if not correction:
        stage.GetPrimAtPath("/root/_materials/checker").CreateAttribute(
            "lantern:bumpMapCorrection", Sdf.ValueTypeNames.Bool, custom=True).Set(False)
    return stage


def centre(stage, **settings):
    settings = dict(dict(width=W, height=H, preset="low", ambient_occlusion=False, fxaa=False),
                    **settings)
    return render_stage(stage, RenderSettings(**settings)).rgba[pixel_of(0, 0)][:3].astype(float)


def smith_g1(alpha2, cos_i):
    tan2 = (1 - cos_i ** 2) / cos_i ** 2
    return 2 / (1 + math.sqrt(1 + alpha2 * tan2))


def sun_stage(tmp_path, correction, elevation_from_zenith):
    """The sun in the plane of the tilt, towards it (sin a, 0, cos a), casting no
    shadow (below the horizon the plane would shadow itself)."""
    stage = tilted_plane(tmp_path, correction)
    sun = UsdLux.DistantLight(stage.GetPrimAtPath("/root/sun"))
    sun.AddRotateYOp().Set(elevation_from_zenith)
    UsdLux.ShadowAPI.Apply(sun.GetPrim()).CreateShadowEnableAttr(False)
    return stage


@pytest.mark.parametrize("zenith", [30.0, 60.0, 80.0])
def test_sun_on_a_bent_normal_is_shadowed_by_smith_g1(tmp_path, zenith):
    corrected = centre(sun_stage(tmp_path, True, zenith))
    plain = centre(sun_stage(tmp_path, False, zenith))
    # Without the correction: Lambert on the bent normal, cos(zenith - 45).
    expected_plain = np.array((0.25, 0.5, 0.75)) * math.cos(math.radians(zenith) - BEND)
    assert np.allclose(plain, expected_plain, rtol=0.03)
    g1 = smith_g1(math.tan(BEND) ** 2 / 8, math.cos(math.radians(zenith)))
    ratio = corrected / plain
    print(f"sun {zenith} deg from zenith: ratio {ratio.round(4)}, Smith G1 {g1:.4f}")
    assert np.allclose(ratio, g1, atol=2e-3)
    assert g1 < 0.99 or zenith < 45       # the case tests something


def test_sun_below_the_smooth_surface_adds_nothing(tmp_path):
    # 100 degrees from the zenith: 55 degrees from the bent normal, so a bent normal
    # alone would be lit; the smooth surface hides the sun.
    plain = centre(sun_stage(tmp_path, False, 100.0))
    corrected = centre(sun_stage(tmp_path, True, 100.0))
    assert np.allclose(plain, np.array((0.25, 0.5, 0.75)) * math.cos(math.radians(55)), rtol=0.03)
    assert np.all(corrected == 0.0)


def dome_share(cos_bend, n=300):
    """The share of a uniform dome's diffuse light the correction keeps at a bend, by
    integration over the sphere (midpoint rule in cos theta and phi); at a right angle,
    the limit from below it."""
    cos_bend = max(cos_bend, 1e-6)
    bend = math.acos(cos_bend)
    normal = np.array([math.sin(bend), 0.0, cos_bend])
    ct = (np.arange(2 * n) + 0.5) / n - 1.0
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * math.pi
    c, p = np.meshgrid(ct, phi, indexing="ij")
    s = np.sqrt(1 - c ** 2)
    dirs = np.stack([s * np.cos(p), s * np.sin(p), c], -1)
    cos_n, cos_s = dirs @ normal, c
    visible = (cos_n > 0) & (cos_s * cos_bend * cos_n >= 0)
    alpha2 = min(max(0.125 * (1 / cos_bend ** 2 - 1), 0.0), 1.0)
    cos_i = np.abs(cos_s)
    g1 = 2 / (1 + np.sqrt(1 + alpha2 * (1 - cos_i ** 2) / np.maximum(cos_i ** 2, 1e-12)))
    return float(np.where(visible, cos_n * g1, 0.0).sum() * (1 / n) * (math.pi / n) / math.pi)


def test_dome_table_is_the_integral():
    table = [float(x) for x in re.search(r"BUMP_DOME\[11\] = float\[\]\(([^)]*)\)",
                                         LIB.read_text()).group(1).split(",")]
    integral = [dome_share(k / 10) for k in range(11)]
    print("table", table, "\nintegral", np.round(integral, 4).tolist())
    assert np.allclose(table, integral, atol=2e-3)


def test_uniform_dome_on_a_bent_normal_keeps_the_tables_share(tmp_path):
    def dome(correction):
        stage = tilted_plane(tmp_path, correction)
        stage.RemovePrim("/root/sun")
        UsdLux.DomeLight.Define(stage, "/root/_world").CreateIntensityAttr(1.0)
        return centre(stage)
    ratio = dome(True) / dome(False)
    expected = dome_share(math.cos(BEND))
    print(f"uniform dome: ratio {ratio.round(4)}, integral {expected:.4f}")
    assert np.allclose(ratio, expected, atol=0.01)   # the table interpolates linearly


def test_no_normal_map_no_extra_target(tmp_path):
    """Model only what a scene needs: a frame without a normal-mapped material has no
    G-buffer target for the smooth normals."""
    from lantern.engine.gpu.framegraph import Frame
    from lantern.engine.gpu.passes.gbuffer import GBufferPass
    from lantern.engine.usd.stage import StageReader

    def read_stage(stage):
        reader = StageReader(stage)
        reader.sync(None)
        reader.close()
        return reader.scene
    plain = read_stage(textured_stage(tmp_path / "missing.png"))
    bent = read_stage(tilted_plane(tmp_path, True))
    off = read_stage(tilted_plane(tmp_path, False))
    wanted = {name: GBufferPass.wanted(None, Frame(scene, None, (1, 1), None))
              for name, scene in (("plain", plain), ("bent", bent), ("off", off))}
    assert wanted == {"plain": (), "bent": ("g_smooth",), "off": ()}
