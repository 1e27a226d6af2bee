"""Shadow planning without a GL context (engine/shadow_plan.py): atlas layouts per
light kind and preset, the order lights get maps in, and which tiles of a kept map
an edit makes stale."""
import numpy as np

from lantern.core.lights import POINT, SPOT, SUN
from lantern.core.presets import preset
from lantern.engine import shadow_plan as S
from lantern.engine.scene import Light

BOUNDS = (np.array([-5.0, -5.0, 0.0]), np.array([5.0, 5.0, 2.0]))


def _light(kind, **kw):
    return Light(kind=kind, name=kind, color=np.ones(3), **kw)


def test_a_spot_is_one_tile_and_a_point_six_cube_faces_at_the_preset_size():
    spot = _light(SPOT, position=np.array([0.0, 0.0, 6.0]), cone_angle=30.0)
    sm = S.plan(spot, 20.0, preset("medium"), BOUNDS, view=None)
    assert (sm.tiles, sm.radial, sm.atlas) == (1, True, (1024, 1024))
    point = _light(POINT, position=np.array([0.0, 0.0, 6.0]), radius=0.1)
    sm = S.plan(point, 20.0, preset("low"), BOUNDS, view=None)
    assert (sm.tiles, sm.atlas) == (6, (3 * 512, 2 * 512))
    assert np.array_equal(sm.anchor, point.position)
    # The map reaches the farthest caster, not the light's whole range.
    far_corner = np.linalg.norm(np.array([5.0, 5.0, 0.0]) - point.position)
    assert far_corner < sm.far < 1.02 * far_corner
    # A light's own resolution wins over the preset's, within the limits.
    big = _light(POINT, position=np.zeros(3), shadow_resolution=100000)
    assert S.resolution(big, preset("low")) == S.MAX_RES


def test_cube_faces_look_along_the_six_axes():
    point = _light(POINT, position=np.zeros(3))
    sm = S.plan(point, 10.0, preset("medium"), BOUNDS, view=None)
    for m, (forward, _) in zip(sm.mats, S.CUBE_FACES):
        p = m @ np.array([*forward, 1.0])
        assert abs(p[0] / p[3]) < 1e-9 and abs(p[1] / p[3]) < 1e-9   # straight ahead


def test_suns_come_first_then_the_brightest_at_the_camera():
    eye = np.zeros(3)
    near = _light(POINT, position=np.array([1.0, 0.0, 0.0]))
    far = _light(POINT, position=np.array([10.0, 0.0, 0.0]))
    sun = _light(SUN)
    order = sorted([far, near, sun], key=lambda light: -S.importance(light, eye))
    assert [light is sun for light in order] == [True, False, False]
    assert order[1] is near and order[2] is far


def test_only_the_tiles_an_edit_falls_in_are_stale():
    point = _light(POINT, position=np.zeros(3))
    sm = S.plan(point, 10.0, preset("medium"), BOUNDS, view=None)
    above = [(np.array([-0.2, -0.2, 3.0]), np.array([0.2, 0.2, 3.5]))]   # +Z face only
    assert S.stale_tiles(sm, point, 10.0, above) == [4]
    out_of_reach = [(np.array([50.0, 50.0, 50.0]), np.array([51.0, 51.0, 51.0]))]
    assert S.stale_tiles(sm, point, 10.0, out_of_reach) == []
    assert S.stale_tiles(sm, point, 10.0, []) == []


def test_a_light_casts_only_with_shadows_on_and_something_to_light():
    assert S.casts(_light(POINT), 1.0)
    assert not S.casts(_light(POINT, shadow=False), 1.0)
    assert not S.casts(_light(POINT), 0.0)
    assert S.casts(_light(SUN), 0.0)
