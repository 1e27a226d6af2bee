"""The measuring ground for the bounce, emitters as lights, area-light highlights and glass
(tests/shot_scenes.py): every shot exports and renders at its size with no warning, and
every committed Cycles reference is there, finite, at that size, and in the mode it
claims. The accuracy goals are the bench's (bench/bench_shots.py); the engine cannot meet
them all yet (glass is drawn refracted since the glass pass: tests/test_glass.py holds its
closed forms; the emitter's goal is asserted in tests/test_emitters.py). What the bounce
reaches so far is held here: the closed box, the emissive panel and the glass ball in
full mode at medium, under bounds the field met (HDR-FLIP against the committed
references)."""
import numpy as np
import pytest

import shot_scenes

WIDTH, HEIGHT = shot_scenes.SIZE


@pytest.mark.parametrize("name", sorted(shot_scenes.SHOTS))
def test_shot_exports_and_renders_without_warnings(name):
    import bpy
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import stage_from_depsgraph
    shot_scenes.build(name)
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    result = render_stage(stage, RenderSettings(width=WIDTH, height=HEIGHT, preset="medium"))
    assert [*report.warnings, *result.warnings] == []
    assert result.rgba.shape == (HEIGHT, WIDTH, 4)
    assert np.isfinite(result.rgba).all()
    assert result.rgba[..., :3].max() > 0.0


def reference(name, mode):
    from lantern.engine import read_exr
    return read_exr(str(shot_scenes.reference_path(name, mode)))


@pytest.mark.parametrize("name,mode", shot_scenes.cases())
def test_reference_is_committed_finite_and_at_the_shot_size(name, mode):
    image = reference(name, mode)
    assert image.shape == (HEIGHT, WIDTH, 3)
    assert np.isfinite(image).all() and image.min() >= 0.0 and image.max() > 0.0


@pytest.mark.parametrize("name", [n for n, s in shot_scenes.SHOTS.items()
                                  if {"full", "direct"} <= set(s.modes)])
def test_full_reference_carries_the_bounce_the_direct_one_lacks(name):
    # The bounce only adds light: a direct reference rendered in full mode (or the
    # other way round) fails here. Pixels Cycles leaves dark in direct mode, lit only
    # by bounced light, carry most of the difference.
    full, direct = reference(name, "full"), reference(name, "direct")
    assert full.mean() > 1.05 * direct.mean()
    unlit = direct.mean(-1) < 1e-3
    if unlit.any():
        assert full.mean(-1)[unlit].mean() > 1e-3


# HDR-FLIP at medium in full mode (Cycles' default bounces) against the committed
# reference, and the bound each holds (2026-11-28: closed box 0.0705, emissive panel
# 0.149; before the field's plane test, its probes at the bounds' faces and its mean of
# the steady light over the updates, 0.094 and 0.196). The glass ball at Cycles' 4 spp
# (0.071): 0.0656 since the checker's cells take the pixel filter and the light a
# leaving interface reflects inside is followed (0.1137 before). 2026-11-29, medium's
# probes 8 along the longest side (were 6): the closed box 0.0596, under Cycles' 16 spp
# (0.066, its bound here: the bounce's acceptance), the panel 0.1248 (0.1414 before),
# the sunlit room 0.1465 (0.1574; Cycles' 4 spp 0.845). Since the final gather (a
# still's last bounce gathered per block of pixels, 32 rays at medium): the closed box
# 0.0468, the panel 0.0963, the sunlit room 0.1301, the glass ball 0.0637. Since medium
# supersamples stills up to 320x240 and a still's field is a preset coarser under its
# gather: 0.0467, 0.0693 (the bounce's acceptance: Cycles' 16 spp, 0.084), 0.1525, 0.0502.
# The box's and the panel's bounds fail with the field alone (RenderSettings(
# final_gather=False), medium's own field: 0.0547, 0.1122); the sunlit room, lit mostly by
# later bounces, is 0.1367 so, and the glass ball 0.0512.
FULL_MODE_BOUNDS = {"cornell_box": 0.052, "emissive_table": 0.084, "glass_sphere": 0.055,
                    "sunlit_room": 0.16}


@pytest.mark.parametrize("name", sorted(FULL_MODE_BOUNDS))
def test_the_bounce_at_medium_stays_near_cycles(name):
    import bpy
    from lantern.compare.metrics import score
    from lantern.engine import RenderSettings, render_stage
    from lantern.exporters import stage_from_depsgraph
    shot_scenes.build(name)
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    result = render_stage(stage, RenderSettings(width=WIDTH, height=HEIGHT, preset="medium"))
    assert result.stats["field_updates"] == 4 and result.stats["gather_rays"] > 0
    flip = score(result.rgba, reference(name, "full"))["all"]["hdr_flip"]
    assert flip < FULL_MODE_BOUNDS[name], f"{name}: HDR-FLIP {flip:.4f}"
