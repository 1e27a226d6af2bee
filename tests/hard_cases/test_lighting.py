"""Lighting: the radiance range. Lights add up in a float32 target (1e-38..3e38), so a
1e-6 W light and a 1e6 W one are both exact where they reach: float16 (the target
before, bench/bench_hdr_target.py) flushed the first to zero and clamped the second at 65504.

- A point light 5 mm above a floor (a mm-sized view, near 1e-4), at 1e-6, 1e-3, 1,
  1e3 and 1e6 W: radiance / power equals the 1 W light's within 1e-5 relative
  wherever both reach (light volumes stop where a white surface reflects less than
  1e-4 W/(sr m2): invisible at exposure 0), with no NaN or Inf.
- A light so strong its radiance overflows float32 gives Inf pixels that are counted
  (stats["nonfinite_pixels"]) and named (a warning with the prim they lie on), not
  masked."""
import numpy as np
import pytest
from pxr import Gf, UsdGeom

from lantern.engine import RenderSettings, render_stage

from hard_cases import engine_scenes as E  # tests/ is on sys.path (conftest.py)
S = E.S
W, H = 96, 54


def _floor_and_light(power, height=5e-3):
    stage = S.new_stage(half=0.05)
    S.add_light(stage, "point", pos=(0.0, 0.0, height), power=power, radius=0.0, shadow=False)
    UsdGeom.Xform.Define(stage, "/view")
    E.camera(stage, "/view/cam", (0.0, -0.02, 0.015), (0.0, 0.0, 0.0), 1e-4, 1.0, focal=20.0)
    return stage


def _render(stage):
    # No FXAA: a filter of the image, not of the light, whose blend weights round
    # differently at different magnitudes (1e-4 relative at edges).
    result = render_stage(stage, RenderSettings(width=W, height=H, fxaa=False))
    return result


@pytest.fixture(scope="module")
def one_watt():
    img = _render(_floor_and_light(1.0)).rgba
    assert np.isfinite(img).all() and img[..., :3].max() > 0
    return img


@pytest.mark.parametrize("power", [1e-6, 1e-3, 1e3, 1e6])
def test_radiance_is_linear_from_1e_6_to_1e6_watts(power, one_watt, hard_case):
    result = _render(_floor_and_light(power))
    img = result.rgba
    assert np.isfinite(img).all() and result.stats["nonfinite_pixels"] == 0
    lit = (img[..., :3] > 0) & (one_watt[..., :3] > 0)
    assert lit.mean() > 0.05                       # the light reaches a good part of the view
    rel = np.abs(img[..., :3][lit] / power - one_watt[..., :3][lit]) / one_watt[..., :3][lit]
    hard_case(f"{power:g} W point light 5 mm above a floor: radiance / power vs 1 W, relative "
              f"(brightest pixel {img[..., :3].max():.3g})", float(rel.max()), 1e-5)


def test_overflowing_radiance_is_counted_and_named(hard_case):
    stage = S.new_stage(half=3.0)
    S.add_light(stage, "point", pos=(0.0, 0.0, 0.3), power=3e38 * np.pi, radius=0.0,
                shadow=False)
    E.camera(stage, "/root/cam", (3.0, -5.0, 3.0), (0.0, 0.0, 0.0), 0.05, 100.0)
    result = _render(stage)
    bad = ~np.isfinite(result.rgba).all(axis=-1)
    count = result.stats["nonfinite_pixels"]
    assert count == int(bad.sum()) > 0                   # counted, and left in the image
    assert any(f"{count} pixels" in w and "/root/plane" in w for w in result.warnings), \
        result.warnings
    hard_case("radiance overflowing float32 (a 3e38 W light 0.3 m over a floor): non-finite "
              "pixels counted = pixels in the image", abs(count - int(bad.sum())), 0, "px")


def test_a_finite_scene_reports_no_non_finite_pixels():
    result = _render(_floor_and_light(1.0))
    assert result.stats["nonfinite_pixels"] == 0
    assert not any("not finite" in w for w in result.warnings)
