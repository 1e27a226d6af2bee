"""Shadows: maps fitted in light-relative space (engine/gpu/passes/shadows.py) keep
their precision wherever the scene is, and the sun's cascades are fitted in lengths
relative to the scene, so a scaled scene casts the same shadows.

- A shadowed point light 0.3 m from a wall, the scene 100, 300, 500 and 1e4 m from
  the origin, renders as at the origin (max abs <= 1e-3); it used to go black.
- A light 1 mm and 1 cm above a floor, at the origin and 1e4 m away, shadowed, renders
  as the same light unshadowed at the origin: no streaks (relative <= 1e-2).
- Sun shadows of a scene scaled by 1e-4 and 1e5 equal the unscaled ones (<= 1e-3).
- An alpha-clipped surface whose alpha is 0 casts no shadow (cut-out shadows,
  docs/rendering.md)."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

from lantern.engine import RenderSettings, render_stage

from hard_cases import engine_scenes as E  # tests/ is on sys.path (conftest.py)
S = E.S
W, H = 160, 90


def _render(stage):
    # No FXAA: its edge thresholds would turn tiny differences into pixel switches.
    rgba = render_stage(stage, RenderSettings(width=W, height=H, fxaa=False)).rgba
    assert np.isfinite(rgba).all()
    return rgba


def _moved(stage, offset, eye, target, near=0.05, far=100.0):
    """/root moved by `offset`; a camera outside it at the moved eye."""
    UsdGeom.Xformable(stage.GetPrimAtPath("/root")).AddTranslateOp().Set(Gf.Vec3d(*offset))
    o = np.asarray(offset, np.float64)
    UsdGeom.Xform.Define(stage, "/view")
    E.camera(stage, "/view/cam", o + eye, o + target, near, far, focal=20.0)
    return stage


def _wall(offset):
    stage = S.new_stage(half=5.0)
    white = UsdShade.Material(stage.GetPrimAtPath("/root/_materials/white"))
    E.quad(stage, "/root/wall", [(-5, 1, 0), (5, 1, 0), (5, 1, 4), (-5, 1, 4)], white, (0, -1, 0))
    S.add_box(stage, (0.8, 0.2, 0.25), 0.5, "box")
    S.add_light(stage, "point", pos=(0, 0.7, 1.0), power=200.0, radius=0.05)
    return _moved(stage, offset, np.array([0.5, -4.0, 2.0]), np.array([0.0, 1.0, 0.8]))


@pytest.fixture(scope="module")
def wall_at_origin():
    img = _render(_wall((0, 0, 0)))
    assert img[..., :3].mean() > 0.3
    return img


@pytest.mark.parametrize("distance", [100.0, 300.0, 500.0, 1e4])
def test_a_shadowed_point_light_near_a_wall_far_from_the_origin(wall_at_origin, distance,
                                                                 hard_case):
    img = _render(_wall((distance, 0.5 * distance, 0.0)))
    hard_case(f"shadowed point light 0.3 m from a wall, {distance:g} m from the origin, "
              f"vs at the origin, max abs (mean {wall_at_origin[..., :3].mean():.2f})",
              np.abs(img - wall_at_origin).max(), 1e-3)


def _light_on_floor(height, offset, shadow):
    stage = S.new_stage(half=5.0)
    S.add_light(stage, "point", pos=(0, 0, height), power=100.0, shadow=shadow)
    # A caster behind the camera, so the map is drawn and its shadow is out of view.
    S.add_box(stage, (0, -8, 0.5), 1.0, "box")
    return _moved(stage, offset, np.array([0.0, -3.0, 2.0]), np.zeros(3))


@pytest.mark.parametrize("height", [1e-3, 1e-2])
def test_a_light_on_a_surface_does_not_streak(height, hard_case):
    ref = _render(_light_on_floor(height, (0, 0, 0), shadow=False))
    worst, mean = 0.0, 0.0
    lit = ref[..., :3].max(-1) > 1e-3
    for offset in ((0, 0, 0), (1e4, 0, 0)):
        img = _render(_light_on_floor(height, offset, shadow=True))
        rel = (np.abs(img - ref)[..., :3] / np.maximum(ref[..., :3], 1e-3)).max(-1)
        worst = max(worst, float(rel[lit].max()))
        mean = max(mean, float(rel[lit].mean()))
    # Grazing light (cos = height / distance) leaves isolated PCF taps partly in the
    # receiver's own texel: a few pixels off by about 1 %, no streaks.
    hard_case(f"light {height:g} m above a floor, shadowed, at 0 and 1e4 m vs unshadowed: "
              f"mean relative over lit pixels", mean, 5e-3)
    hard_case(f"light {height:g} m above a floor, shadowed, at 0 and 1e4 m vs unshadowed: "
              f"worst pixel, relative", worst, 5e-2)


@pytest.mark.parametrize("scale", [1e-4, 1e5])
def test_sun_shadows_do_not_change_with_the_scale(scale, hard_case):
    ref = _render(E.far_scene(point=False))
    img = _render(E.far_scene(scale=scale, point=False))
    unshadowed = E.far_scene(point=False)
    UsdLux.ShadowAPI(unshadowed.GetPrimAtPath("/root/sun")).GetShadowEnableAttr().Set(False)
    assert (np.abs(_render(unshadowed) - ref).max(-1) > 0.1).mean() > 0.005  # shadows in view
    hard_case(f"sun shadows, scene scaled by {scale:g} vs unscaled, max abs",
              np.abs(img - ref).max(), 1e-3)


def test_an_alpha_zero_clipped_surface_casts_no_shadow(hard_case):
    def scene(with_card):
        stage = S.new_stage(half=5.0)
        S.add_light(stage, "sun", strength=3.0, dir=(0.3, 0.2, -1.0))
        if with_card:
            mat = E.material(stage, "clear", (1, 1, 1))
            sh = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/clear/surface"))
            sh.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(0.0)
            sh.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
            E.quad(stage, "/root/card", [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)],
                   mat, (0, 0, 1))
        return _moved(stage, (0, 0, 0), np.array([0.0, -4.0, 4.0]), np.zeros(3))
    diff = np.abs(_render(scene(True)) - _render(scene(False))).max()
    hard_case("alpha-0 clipped card: its shadow, max abs", diff, 1e-3)
