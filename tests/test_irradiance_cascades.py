"""The irradiance field's grids (engine/probe_grids.py): one over small bounds, nested
camera-centred cascades over large ones."""
import numpy as np

import shadow_scenes
import shot_scenes
from lantern.engine import RenderSettings, Session, probe_grids
from lantern.engine.bounces import DIRECT, Bounces
from lantern.engine.probe_grids import NEAR, grids, placement
from test_irradiance_field import _material, _quad

SIZE = dict(width=48, height=32)
EYE = (-1.8, -1.7, 1.5)
TARGET = (1.0, 0.6, 0.7)
FORWARD = tuple(np.subtract(TARGET, EYE) / np.linalg.norm(np.subtract(TARGET, EYE)))


def test_small_bounds_get_one_grid_and_large_ones_nested_cascades_about_the_camera():
    assert placement((-6, -6, 0), (6, 8, 3), EYE, FORWARD) is None        # the demo's size
    assert placement((-12, -12, 0), (12, 12, 2.6), EYE, FORWARD) is None  # a room on a ground
    lo, hi = np.array([-100.0, -100.0, 0.0]), np.array([100.0, 100.0, 2.6])
    centre = placement(lo, hi, EYE, FORWARD)
    made = grids(lo, hi, 6, centre)
    assert len(made) == 6                       # 8, 16, 32, 64, 128 m, then the bounds
    whole = grids(lo, hi, 6)[0]
    np.testing.assert_array_equal(made[-1].first, whole.first)
    for g, finer in zip(made[1:-1], made):
        np.testing.assert_allclose(g.step[:2], 2 * finer.step[:2])   # twice the side
    for i, g in enumerate(made[:-1]):
        assert g.counts[0] == g.counts[1] == 6 and g.counts[2] <= 6
        side = NEAR * 2 ** i
        np.testing.assert_allclose(g.counts[:2] * g.step[:2], side)
        # About the camera (centred a little ahead of it), inside the bounds.
        assert np.all(g.region_lo[:2] < EYE[:2]) and np.all(EYE[:2] < g.region_hi[:2])
        assert np.all(g.first >= lo) and np.all(g.first + (g.counts - 1) * g.step <= hi)
    # They follow the camera by steps: a small move keeps them, a larger one moves them.
    assert placement(lo, hi, (-1.6, -1.8, 1.5), FORWARD) == centre
    assert placement(lo, hi, (5.0, -1.7, 1.5), FORWARD) != centre


def lit_room_stage(ground_half):
    """A closed white room of zero-thickness walls, 4 x 4 x 2.6 m, lit by a lamp inside,
    on a ground `ground_half` metres about it. The camera inside."""
    stage = shadow_scenes.new_stage(half=ground_half)
    white = _material(stage, "white2", (0.8, 0.8, 0.8))
    red = _material(stage, "red", (0.8, 0.1, 0.1))
    for name, corners in shot_scenes.room_walls((-2, -2, 0.0), (2, 2, 2.6)).items():
        _quad(stage, name, corners, red if name == "wall_xp" else white)
    shadow_scenes.add_box(stage, center=(0.6, 0.5, 0.5), size=1.0)
    shadow_scenes.add_light(stage, "point", pos=(0.5, -0.5, 2.2), power=300.0, radius=0.05,
                            shadow=False)
    shadow_scenes.add_camera(stage, eye=EYE, target=TARGET, aspect=1.5, far=300.0)
    return stage


def _bounce(stage):
    """The field's own light (as a viewport shows it: no final gather, whose field is a
    preset coarser) less the direct image."""
    with Session(stage, RenderSettings(**SIZE, bounces=DIRECT)) as s:
        direct = s.render()
    with Session(stage, RenderSettings(**SIZE, bounces=Bounces(), final_gather=False)) as s:
        full = s.render()
    return full.rgba[..., :3] - direct.rgba[..., :3], full.stats


def test_a_large_ground_gets_cascades_whose_near_light_matches_a_fine_grid(monkeypatch):
    # One grid whose probes are the finest cascade's (6 at NEAR / 6 apart over 8 m about
    # the camera): a ground whose outermost probes lie probe_grids.INSET of a spacing in.
    spacing = NEAR / 6
    fine, stats = _bounce(lit_room_stage((5 + 2 * probe_grids.INSET) * spacing / 2))
    assert stats["field_grids"] == 1
    cascaded, stats = _bounce(lit_room_stage(100.0))     # 200 m: cascades
    assert stats["field_grids"] == 6
    monkeypatch.setattr(probe_grids, "CASCADE_AFTER", 1e9)
    coarse, stats = _bounce(lit_room_stage(100.0))       # one grid, 33 m apart
    assert stats["field_grids"] == 1
    scale = float(fine.mean())
    assert scale > 0.02
    near = float(np.abs(cascaded - fine).mean()) / scale
    far = float(np.abs(coarse - fine).mean()) / scale
    print(f"bounce error against a fine grid: cascades {near:.3f}, one coarse grid {far:.3f}")
    assert near < 0.05
    assert far > 0.5


def _look(stage, eye, target):
    from pxr import Gf, UsdGeom
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(0, 0, 1))
    UsdGeom.Camera(stage.GetPrimAtPath("/root/cam")).GetOrderedXformOps()[0].Set(m.GetInverse())


def test_the_cascades_follow_the_camera_and_a_viewport_keeps_its_field_until_they_converged():
    stage = lit_room_stage(100.0)
    settings = RenderSettings(**SIZE, bounces=Bounces(), progressive_field=True)
    with Session(stage, settings) as s:
        while s.render().stats["field_pending"]:
            pass
        _look(stage, (-1.6, -1.8, 1.5), TARGET)            # within a step: kept
        near = s.render()
        assert near.stats["field_rays"] == 0
        _look(stage, (1.5, -1.7, 1.5), (1.0, 1.5, 0.7))    # across the room: placed again
        frames = [s.render()]
        while frames[-1].stats["field_pending"]:
            frames.append(s.render())
    assert len(frames) > 2 and frames[0].stats["field_rays"] > 0
    # Meanwhile the old field, converged (never a partial one of the new place): the
    # same image until the last frame.
    assert sum(f.stats["field_updates"] for f in frames) == 4
    assert all(np.array_equal(f.rgba, frames[0].rgba) for f in frames[:-1])
    assert not np.array_equal(frames[-1].rgba, frames[0].rgba)
    # The still's field, without the final gather a still adds to it (a viewport's
    # frames show the field).
    with Session(stage, RenderSettings(**SIZE, bounces=Bounces(), final_gather=False)) as s:
        still = s.render()
    assert still.stats["field_grids"] == 6
    np.testing.assert_array_equal(frames[-1].rgba, still.rgba)
