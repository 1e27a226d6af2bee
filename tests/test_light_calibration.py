"""Blender's light units, end to end: a Blender scene, exported, rendered by Lantern,
against the closed forms of `calibration.py` and against committed Cycles renders."""
import pathlib

import numpy as np
import pytest

import calibration

REFERENCES = pathlib.Path(__file__).resolve().parent / "references"


def _lit_mask(reference):
    """Pixels that receive at least 5% of the peak radiance."""
    return reference > 0.05 * reference.max()


def _relative_errors(image, reference):
    mask = _lit_mask(reference)
    return (image[mask] - reference[mask]) / reference[mask]


def _cycles(kind):
    from lantern.engine.image_io import read_exr
    return read_exr(str(REFERENCES / f"cycles_{kind}.exr"))[..., 0].astype(np.float64)


def _lantern(kind, energy=None):
    import bpy
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    from lantern.exporters import stage_from_depsgraph
    calibration.build_scene(kind)
    if energy is not None:
        bpy.data.lights[kind].energy = energy
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    result = render_stage(stage, RenderSettings(width=calibration.SIZE, height=calibration.SIZE,
                                                 supersample=1, bounces=DIRECT))   # direct light's units
    assert np.isfinite(result.rgba).all()
    return result.rgba[..., 0].astype(np.float64)


@pytest.mark.parametrize("kind", sorted(calibration.LIGHTS))
def test_cycles_agrees_with_the_closed_form(kind):
    """The committed Cycles renders (4096 spp, direct light) agree within 0.1%."""
    errors = _relative_errors(_cycles(kind), calibration.closed_form_radiance(kind))
    assert np.abs(errors).mean() < 1e-3, f"{kind}: mean |rel| {np.abs(errors).mean():.5f}"


@pytest.mark.parametrize("kind", sorted(calibration.LIGHTS))
def test_lantern_matches_the_closed_form(kind):
    """Every lit pixel within 2% of Blender's light units; the mean within 0.5%."""
    reference = calibration.closed_form_radiance(kind)
    errors = _relative_errors(_lantern(kind), reference)
    worst, mean = np.abs(errors).max(), np.abs(errors).mean()
    print(f"{kind}: mean |rel err| {mean:.5f}, max {worst:.5f}")
    assert worst <= 0.02, f"{kind}: worst relative error {worst:.4f}"
    assert mean <= 0.005, f"{kind}: mean relative error {mean:.4f}"


@pytest.mark.parametrize("energy", [1e-6, 1e6])
@pytest.mark.parametrize("kind", sorted(calibration.LIGHTS))
def test_lantern_calibration_holds_from_a_microwatt_to_a_megawatt(kind, energy):
    """The same scenes with the light at 1e-6 and 1e6 W (W/m2 for the sun): every lit
    pixel within 2%. A 1e-6 W point light reflects ~6e-9 W/(sr m2) here; it rendered
    0 while light volumes ended where a light reflected 1e-4 W/(sr m2), whatever the
    scene's own level."""
    reference = calibration.closed_form_radiance(kind) * (energy / calibration.LIGHTS[kind]["energy"])
    errors = _relative_errors(_lantern(kind, energy), reference)
    print(f"{kind} at {energy:g} W: worst |rel err| {np.abs(errors).max():.2e}")
    assert np.abs(errors).max() <= 0.02, f"{kind} at {energy:g} W: {np.abs(errors).max():.4f}"


def test_the_closed_form_check_can_fail():
    """A light 3% too bright is caught by the 2% bound."""
    reference = calibration.closed_form_radiance("point")
    assert np.abs(_relative_errors(reference * 1.03, reference)).max() > 0.02
