"""`lantern compare`'s warm Lantern time from nothing: Session.drop_traced makes the
next render build the ray tracer's trees and the irradiance field again (as Cycles'
time includes its BVH), without reading the stage or uploading meshes again."""
import numpy as np

from lantern.engine import RenderSettings, Session

from test_irradiance_field import SIZE, room_stage


def test_a_render_after_drop_traced_builds_the_field_from_nothing():
    with Session(room_stage((12, 4, 4)), RenderSettings(**SIZE)) as s:
        first = s.render()
        kept = s.render()
        s.drop_traced()
        rebuilt = s.render()
    assert first.stats["field_updates"] == 4          # the scene's diffuse bounces
    assert kept.stats["field_updates"] == 0
    assert rebuilt.stats["field_updates"] == 4
    assert rebuilt.stats["meshes_uploaded"] == 0 and rebuilt.stats["prims_read"] == 0
    np.testing.assert_allclose(rebuilt.rgba, first.rgba, rtol=2 ** -10, atol=1e-4)
