"""Against Cycles, direct light only: a white box on a white plane per light type,
rendered once by Cycles (2048 spp, bounces 0, fixed seed, no denoiser; committed EXRs
from references/make_cycles_references.py box) and by Lantern at the medium preset.

The thresholds are the measured mean HDR-FLIP (2026-11-21, llvmpipe) plus about 25%,
so a regression in lights or shadows fails here:
    sun 0.0006, point 0.0034, spot 0.0501, area 0.0073.
Area lights filter over their own extent (shaders/shadow_lookup.glsl):
area 0.0043 (2026-11-23; 0.0060 with the new shading alone), its threshold
tightened to match.
The spot's figure is the largest: its cone edge, softened by the light's radius, is
approximated by a 7-point average over the light's disk (shaders/light.frag)."""
import pathlib


import pytest

import calibration
from image_metrics import mean_flip, psnr

REFERENCES = pathlib.Path(__file__).resolve().parent / "references"
THRESHOLDS = {"sun": 0.00075, "point": 0.0043, "spot": 0.063, "area": 0.0054}


@pytest.mark.parametrize("kind", sorted(calibration.BOX_LIGHTS))
def test_box_on_plane_against_cycles(kind):
    import bpy
    from lantern.engine import RenderSettings, read_exr, render_stage
    from lantern.engine.bounces import DIRECT      # the references: Cycles, bounces 0
    from lantern.exporters import stage_from_depsgraph
    calibration.build_box_scene(kind)
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    width, height = calibration.BOX_SIZE
    # The references are point-sampled (0.01 px filter): compare without anti-aliasing.
    result = render_stage(stage, RenderSettings(width=width, height=height, preset="medium",
                                                fxaa=False, supersample=1, bounces=DIRECT))
    assert result.stats["shadow_maps"] == 1
    cycles = read_exr(str(REFERENCES / f"cycles_box_{kind}.exr"))
    flip = mean_flip(result.rgba, cycles)
    print(f"{kind}: mean HDR-FLIP {flip:.4f} (threshold {THRESHOLDS[kind]}), "
          f"PSNR {psnr(result.rgba, cycles):.1f} dB")
    assert flip < THRESHOLDS[kind]


def test_the_flip_check_sees_a_missing_shadow():
    """The same scene with Cast Shadow off is far above the threshold."""
    import bpy
    from lantern.engine import RenderSettings, read_exr, render_stage
    from lantern.engine.bounces import DIRECT      # the references: Cycles, bounces 0
    from lantern.exporters import stage_from_depsgraph
    calibration.build_box_scene("point")
    bpy.data.lights["point"].use_shadow = False
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    width, height = calibration.BOX_SIZE
    result = render_stage(stage, RenderSettings(width=width, height=height, fxaa=False,
                                                supersample=1, bounces=DIRECT))
    cycles = read_exr(str(REFERENCES / "cycles_box_point.exr"))
    assert mean_flip(result.rgba, cycles) > 3 * THRESHOLDS["point"]
