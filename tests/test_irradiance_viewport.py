"""The irradiance field in a viewport (RenderSettings.progressive_field): a ray budget a
frame, converging over frames to the field a still makes; stills stay converged."""
import numpy as np
from pxr import Gf, UsdGeom

from lantern.engine import RenderSettings, Session
from lantern.engine.gpu.passes.irradiance import BUDGET
from test_irradiance_field import SIZE, room_stage

MAX_FRAMES = 40


def _converge(session):
    """The viewport's frames until its field has no rays to go: their results."""
    frames = []
    for _ in range(MAX_FRAMES):
        frames.append(session.render())
        if frames[-1].stats["field_pending"] == 0:
            return frames
    raise AssertionError(f"not converged in {MAX_FRAMES} frames")


def _still(stage, **settings):
    """A still's image of the field alone: a viewport's frames show the field, to which a
    still adds its final gather (test_a_still_gathers_its_last_bounce_a_viewport_does_not)."""
    settings.setdefault("final_gather", False)
    with Session(stage, RenderSettings(**SIZE, **settings)) as s:
        return s.render()


def test_viewport_frames_converge_to_the_stills_image_within_the_ray_budget():
    stage = room_stage((12, 4, 4))
    still = _still(stage)
    assert still.stats["field_pending"] == 0 and still.stats["field_updates"] == 4
    whole = still.stats["field_rays"]
    with Session(stage, RenderSettings(**SIZE, progressive_field=True)) as s:
        frames = _converge(s)
        steady = s.render()
    traced = [f.stats["field_rays"] for f in frames]
    assert max(traced) <= BUDGET["medium"], traced
    assert sum(traced) == whole                 # the still's rays, spread over frames
    assert len(frames) == -(-whole // BUDGET["medium"])
    # Meanwhile each frame shows the last complete update (none yet: the direct image).
    assert frames[0].stats["field_updates"] == 0
    assert sum(f.stats["field_updates"] for f in frames) == 4
    assert all(np.isfinite(f.rgba).all() for f in frames)
    assert not np.array_equal(frames[0].rgba, still.rgba)
    np.testing.assert_array_equal(frames[-1].rgba, still.rgba)
    assert steady.stats["field_rays"] == 0
    np.testing.assert_array_equal(steady.rgba, still.rgba)


def test_a_viewport_edit_shows_its_first_bounce_then_converges_to_the_edited_still():
    stage = room_stage((12, 4, 4))
    light = UsdGeom.Xformable(stage.GetPrimAtPath("/root/point"))
    with Session(stage, RenderSettings(**SIZE, progressive_field=True)) as s:
        before = _converge(s)[-1]
        light.GetOrderedXformOps()[0].Set(Gf.Vec3d(-0.5, 0.5, 2.0))
        frames = _converge(s)
    moved = _still(stage)
    # Until the edit's first update is complete, the field as it was; then its updates.
    first = next(i for i, f in enumerate(frames) if f.stats["field_updates"])
    assert first > 0
    assert max(f.stats["field_rays"] for f in frames) <= BUDGET["medium"]
    assert not np.array_equal(frames[first].rgba, before.rgba)
    np.testing.assert_array_equal(frames[-1].rgba, moved.rgba)


def test_a_moving_views_coarser_preset_keeps_the_field_and_a_still_makes_its_own():
    stage = room_stage((12, 4, 4))
    with Session(stage, RenderSettings(**SIZE, progressive_field=True)) as s:
        _converge(s)
        s.configure(preset="low")                # the interactive preset of a moving view
        moving = s.render()
        assert moving.stats["field_rays"] == 0
        # Half way through a field, a still (F12, a sequence's frame) makes its own: its
        # final gather reads a field a preset coarser (medium's still: low's).
        s.configure(preset="medium")
        light = UsdGeom.Xformable(stage.GetPrimAtPath("/root/point"))
        light.GetOrderedXformOps()[0].Set(Gf.Vec3d(-0.5, 0.5, 2.0))
        assert s.render().stats["field_pending"] > 0
        s.configure(progressive_field=False)
        final = s.render()
        s.configure(preset="low")
        low = s.render()
    assert final.stats["field_pending"] == 0 and final.stats["field_updates"] == 4
    # Stills, as F12 makes them: with their final gather.
    np.testing.assert_array_equal(final.rgba, _still(stage, final_gather=None).rgba)
    # A low still gathers over a field of low's density too: the medium still's serves.
    assert low.stats["field_updates"] == 0
    np.testing.assert_array_equal(low.rgba, _still(stage, preset="low", final_gather=None).rgba)


def test_a_still_gathers_its_last_bounce_a_viewport_does_not():
    """A still (F12, the command line, a sequence's frame) gathers the diffuse bounce per
    block of pixels over the field it builds; a viewport's frames show the field with the
    screen's near field, and final_gather turns the gather on or off either way."""
    stage = room_stage((12, 4, 4))
    with Session(stage, RenderSettings(**SIZE)) as s:
        gathered = s.render()
    plain = _still(stage)
    assert gathered.stats["gather_rays"] > 0 and "gather_rays" not in plain.stats
    assert not np.array_equal(gathered.rgba, plain.rgba)
    with Session(stage, RenderSettings(**SIZE, progressive_field=True)) as s:
        frames = _converge(s)
    assert all("gather_rays" not in f.stats for f in frames)
    with Session(stage, RenderSettings(**SIZE, progressive_field=True, final_gather=True)) as s:
        assert s.render().stats.get("gather_rays", 0) == 0      # no complete field yet
        assert _converge(s)[-1].stats["gather_rays"] > 0
        # After an edit, not until the field is made again for the scene as it is (the
        # field shown meanwhile, and its tables, are the old scene's).
        light = UsdGeom.Xformable(stage.GetPrimAtPath("/root/point"))
        light.GetOrderedXformOps()[0].Set(Gf.Vec3d(-0.5, 0.5, 2.0))
        frames = _converge(s)
        assert frames[0].stats.get("gather_rays", 0) == 0
        assert frames[-1].stats["gather_rays"] > 0
