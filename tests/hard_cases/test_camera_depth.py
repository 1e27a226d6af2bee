"""Camera and depth: camera-relative rendering and reversed float depth (engine/view.py).

- A scene 1e3, 1e5 and 1e6 m from the origin renders like the same scene at the
  origin, and so does the scene scaled to 1e-4 and 1e5 (its camera scaled too):
  max abs difference <= 1e-3 on an image of mean ~0.4.
- Two surfaces 1 mm apart at 100 m, near 1e-3 and far 1e5, never z-fight, whichever
  is drawn first: every pixel shows the front one.
- Position from depth (lib.glsl's position_from_depth, read back) is within 1e-4
  of the exact ray-plane hit, relative to the distance, from 1e-2 to 1e4 m.
- The GL 3.3 fallback (no glClipControl: NDC [-1, 1]) is measured, not bounded as
  tightly: its rounding near NDC -1 limits it to ~6e-8 absolute in n/d.
Every image is finite."""
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

from hard_cases import engine_scenes as E  # tests/ is on sys.path (conftest.py)
from lantern.engine import RenderSettings, render_stage

W, H = 160, 90
BOUND = 1e-3


def _render(stage, w=W, h=H):
    # No FXAA: its edge thresholds would turn the 1e-5 differences measured here into
    # whole-pixel switches.
    rgba = render_stage(stage, RenderSettings(width=w, height=h, fxaa=False, supersample=1)).rgba
    assert np.isfinite(rgba).all()
    return rgba


@pytest.fixture(scope="module")
def at_origin():
    img = _render(E.far_scene())
    assert 0.1 < float(img[..., :3].mean()) < 0.6
    return img


@pytest.mark.parametrize("distance", [1e3, 1e5, 1e6])
def test_far_from_the_origin_renders_as_at_the_origin(at_origin, distance, hard_case):
    img = _render(E.far_scene(offset=(distance, -0.7 * distance, 0.3 * distance)))
    hard_case(f"scene {distance:g} m from the origin vs at the origin, max abs "
              f"(image mean {at_origin[..., :3].mean():.2f})",
              np.abs(img - at_origin).max(), BOUND)


@pytest.mark.parametrize("scale", [1e-4, 1e5])
def test_a_scaled_scene_renders_as_the_unscaled_one(at_origin, scale, hard_case):
    img = _render(E.far_scene(scale=scale))
    hard_case(f"scene and camera scaled by {scale:g} vs unscaled, max abs",
              np.abs(img - at_origin).max(), BOUND)


def _two_surfaces(front_first: bool, tilt: float, gap=1e-3):
    """Two 40 m squares `gap` apart facing a camera 100 m away (tilted by `tilt`
    degrees), red in front, green behind. Batches draw in material-name order, so the
    names choose which surface is drawn first."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    first, second = ("a", "b") if front_first else ("b", "a")
    red = E.material(stage, f"{first}_front", (1, 0, 0))
    green = E.material(stage, f"{second}_back", (0, 1, 0))
    s = 20.0
    sq = [(-s, -s), (s, -s), (s, s), (-s, s)]
    E.quad(stage, "/root/front", [(x, y, 0.0) for x, y in sq], red, (0, 0, 1))
    E.quad(stage, "/root/back", [(x, y, -gap) for x, y in sq], green, (0, 0, 1))
    t = np.radians(tilt)
    eye = (0.0, -100.0 * np.sin(t), 100.0 * np.cos(t))
    E.camera(stage, "/root/cam", eye, (0, 0, 0), 1e-3, 1e5, focal=50.0, up=(0, 1, 0))
    return stage


@pytest.mark.parametrize("tilt", [0.0, 60.0])
def test_surfaces_1mm_apart_at_100m_do_not_z_fight(tilt, hard_case):
    worst = 0
    for front_first in (True, False):
        img = _render(_two_surfaces(front_first, tilt))
        covered = img[..., 3] > 0
        assert covered.mean() > 0.2
        fights = int(np.sum(covered & (img[..., 1] > img[..., 0])))
        worst = max(worst, fights)
    hard_case(f"1 mm apart at 100 m (near 1e-3, far 1e5, view {tilt:g} deg off the normal), "
              f"either draw order: pixels showing the back surface", worst, 0, "px")


def _plane_stage(distance, tilt_deg):
    """A plane `distance` from the camera along its axis, tilted, a little wider than
    the view (triangles reaching far outside the screen lose interpolation precision
    in the rasteriser: a 1e6 m plane seen from 1 m is 1% off on llvmpipe)."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    s = 1.5 * distance
    t = np.radians(tilt_deg)
    # The plane through (0, 0, -distance) whose normal leans by `tilt` about x.
    n = np.array([0.0, np.sin(t), np.cos(t)])
    u = np.array([1.0, 0.0, 0.0])
    v = np.cross(n, u)
    c = np.array([0.0, 0.0, -distance])
    corners = [c + s * (a * u + b * v) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    E.quad(stage, "/root/plane", corners, E.material(stage, "grey", (0.5, 0.5, 0.5)), n)
    E.camera(stage, "/root/cam", (0, 0, 0), (0, 0, -1), 1e-3, 1e7, focal=35.0, up=(0, 1, 0))
    return stage, n, c


def _position_error(distance, tilt=30.0):
    """Worst |position from depth - exact ray hit| / |exact ray hit| over the image."""
    stage, n, c = _plane_stage(distance, tilt)
    pos, depth, view = E.positions_from_depth(stage, RenderSettings(width=64, height=36, supersample=1))
    drawn = pos[..., 3] > 0
    assert drawn.mean() > 0.5
    rays = E.pixel_rays(view, 64, 36)
    eye = np.asarray(view.origin)
    t = ((c - eye) @ n) / (rays @ n)
    exact = rays * t[..., None]
    err = np.linalg.norm(pos[..., :3] - exact, axis=-1) / np.linalg.norm(exact, axis=-1)
    return float(err[drawn].max())


@pytest.mark.parametrize("distance", [1e-2, 1.0, 100.0, 1e4])
def test_position_from_depth(distance, hard_case):
    hard_case(f"position from depth at {distance:g} m (near 1e-3), relative to the distance",
              _position_error(distance), 1e-4)


@pytest.mark.parametrize("distance", [1.0, 100.0, 1e4])
def test_position_from_depth_on_the_gl33_fallback(distance, hard_case, monkeypatch):
    """Without glClipControl the window depth n/d comes through NDC 2n/d - 1: its
    rounding near -1 costs ~6e-8 absolute in n/d, so relative error grows as d/n."""
    monkeypatch.setenv("LANTERN_MAX_GL", "33")
    err = _position_error(distance)
    hard_case.record(f"GL 3.3 fallback: position from depth at {distance:g} m (near 1e-3), "
                     f"relative", err)
    assert err <= 1e-7 * distance / 1e-3 + 1e-6


def test_the_z_fighting_check_sees_a_fight():
    """Negative control: with no gap, the surface drawn first (the back one) keeps
    every pixel (GREATER fails on ties), and the check sees it."""
    img = _render(_two_surfaces(False, 60.0, gap=0.0))
    assert int(np.sum((img[..., 3] > 0) & (img[..., 1] > img[..., 0]))) > 0
