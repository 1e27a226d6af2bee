"""The compute forms against the raster forms, on the scenes the other tests hold to
Cycles and to closed forms: with the light tree's error bound at 0 (every light on its
own, cut where its volume ends), the clustered light pass, the screen passes in compute
(engine/gpu/screen.py) and compute skinning give the images that the light volumes,
the full-screen fragment passes and transform feedback give, within float16 rounding
(the G-buffer's targets are half floats). So every bound those tests hold on the
default form (raster on llvmpipe, compute on a GPU) holds on the other too. Those tests
render the reference and calibration scenes in direct mode (their Cycles references and
closed forms have no bounce), and so do these; the demo's every-pass test at low keeps
its scene's bounces, so the field's and the reflections' reads are held in both forms."""
import numpy as np
import pytest

import calibration
import reference_scenes
from lantern.core.passes import PASSES
from lantern.engine import RenderSettings, render_stage
from lantern.engine.bounces import DIRECT

RASTER = dict(compute=False, lighting="volumes")
COMPUTE = dict(compute=True, lighting="clustered", light_error=0.0)
HALF = 2.0 ** -10            # float16's relative rounding


def both(stage, **settings):
    """(raster, compute) results of one stage, after checking each ran in its form.
    The stage's own bounces unless `settings` name them."""
    raster = render_stage(stage, RenderSettings(**settings, **RASTER))
    compute = render_stage(stage, RenderSettings(**settings, **COMPUTE))
    assert "light_cull" not in raster.stats["passes"]
    if stage_has_lights(compute):
        assert "light_cull" in compute.stats["passes"]
    return raster, compute


def quads_stage(quads):
    """An in-memory stage, Z up, of horizontal squares: {path: (height, half side)}."""
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    for path, (z, half) in quads.items():
        quad = UsdGeom.Mesh.Define(stage, path)
        quad.CreateSubdivisionSchemeAttr("none")
        quad.CreatePointsAttr([(-half, -half, z), (half, -half, z), (half, half, z),
                               (-half, half, z)])
        quad.CreateFaceVertexCountsAttr([4])
        quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    return stage


def test_a_software_rasteriser_gets_the_raster_forms_and_clustered_lights():
    """Left to Lantern, llvmpipe (this suite's device) draws the raster forms of the
    screen passes and skinning (compute gains nothing on a CPU), and clustered lights
    (volumes would cut their tails)."""
    from light_grids import add_sphere_lights
    stage = quads_stage({"/root/plane": (0.0, 5.0)})
    add_sphere_lights(stage, "/root", [(0.0, 0.0, 1.0)], {"intensity": 50.0, "radius": 0.05},
                      False, treat_as_point=True)
    left = render_stage(stage, RenderSettings(width=16, height=16, preset="low"))
    assert left.stats["gpu_software"]
    assert left.stats["forms"] == {"compute": False, "lighting": "clustered"}
    assert "light_cull" in left.stats["passes"]
    asked = render_stage(stage, RenderSettings(width=16, height=16, compute=True))
    assert asked.stats["forms"] == {"compute": True, "lighting": "clustered"}
    raster = render_stage(stage, RenderSettings(width=16, height=16, compute=False))
    assert raster.stats["forms"] == {"compute": False, "lighting": "volumes"}


def test_a_software_rasteriser_draws_each_light_with_a_map_as_its_volume():
    """Left to Lantern on llvmpipe, a light with its own shadow map (a pass of its own
    in either form) is drawn as its light volume, as the other screen passes are
    raster there; the lights without one are clustered. The image is the compute
    form's, within float16 rounding."""
    from pxr import UsdGeom
    from light_grids import add_sphere_lights
    stage = quads_stage({"/root/plane": (0.0, 5.0), "/root/caster": (0.5, 0.3)})
    UsdGeom.Xform.Define(stage, "/root/shadowed")
    add_sphere_lights(stage, "/root", [(1.0, 0.0, 1.0)], {"intensity": 50.0, "radius": 0.05},
                      False, treat_as_point=True)
    add_sphere_lights(stage, "/root/shadowed", [(0.0, 0.0, 1.5)],
                      {"intensity": 80.0, "radius": 0.1}, True)
    settings = dict(width=48, height=48, preset="low", light_error=0.0,
                    passes=frozenset({"DiffDir", "GlossDir", "Shadow"}))
    left = render_stage(stage, RenderSettings(**settings))
    assert left.stats["forms"] == {"compute": False, "lighting": "clustered"}
    assert left.stats["shadow_maps"] == 1 and left.stats["light_volumes"] == 1
    assert "light_cull" in left.stats["passes"]
    compute = render_stage(stage, RenderSettings(**settings, compute=True))
    assert compute.stats["light_volumes"] == 0
    assert_results_same(left, compute, "default forms")


def stage_has_lights(result) -> bool:
    return "lights" in result.stats["passes"]


def assert_same(a, b, what):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    assert np.isfinite(a).all() == np.isfinite(b).all(), what
    worst = np.abs(a - b) / np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-6)
    assert worst.max() <= HALF, f"{what}: {worst.max():.3g}"


def assert_results_same(raster, compute, what):
    assert_same(raster.rgba, compute.rgba, what)
    assert set(raster.passes) == set(compute.passes)
    for name in raster.passes:
        assert_same(raster.passes[name], compute.passes[name], f"{what} {name}")
    assert raster.stats["nonfinite_pixels"] == compute.stats["nonfinite_pixels"]


@pytest.fixture(scope="module")
def stage_of():
    import test_looks
    return test_looks.stage_of


@pytest.mark.parametrize("name", sorted(reference_scenes.SCENES))
def test_reference_scenes(name, stage_of):
    import test_looks
    w, h = reference_scenes.SCENES[name].size
    raster, compute = both(stage_of(name), width=w // 2, height=h // 2,
                           frame=test_looks.FRAMES.get(name), bounces=DIRECT)
    assert_results_same(raster, compute, name)


@pytest.mark.parametrize("preset, bounces", [("low", None), ("ultra", DIRECT)],
                         ids=["low", "ultra"])
def test_every_render_pass_and_the_post_chain(preset, bounces, stage_of):
    """Every render pass, supersampled or not, and each post stage; at low with the
    demo's bounces (the field and the reflections), at ultra (3x3 supersampled, nine
    times the reflections' rays) in direct mode."""
    w, h = reference_scenes.SCENES["demo"].size
    raster, compute = both(stage_of("demo"), width=w // 2, height=h // 2, frame=13.0,
                           preset=preset, passes=frozenset(PASSES) - {"Combined"},
                           exposure=0.5, blur=1.0, grayscale=True, mirror="x", bounces=bounces)
    bounced = raster.stats["field_updates"] > 0 and compute.stats["field_updates"] > 0
    assert bounced == (bounces is None)
    assert_results_same(raster, compute, f"demo {preset}")


@pytest.mark.parametrize("kind", sorted(calibration.LIGHTS))
def test_calibration_scenes(kind):
    """Each light kind, with and without its shadow map."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    calibration.build_scene(kind)
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    raster, compute = both(stage, width=calibration.SIZE, height=calibration.SIZE,
                           passes=frozenset({"DiffDir", "GlossDir", "Shadow"}), bounces=DIRECT)
    assert_results_same(raster, compute, kind)


@pytest.mark.parametrize("name", ["transparency_planes", "cutout_shadow", "01_alpha_blend"])
def test_transparency_scenes(name, stage_of):
    w, h = reference_scenes.SCENES[name].size
    raster, compute = both(stage_of(name), width=w, height=h, transparent=True, bounces=DIRECT)
    assert_results_same(raster, compute, name)


def test_skinned_crowd():
    from skel_scenes import crowd_stage
    raster, compute = both(crowd_stage(), width=96, height=64, frame=7.0)
    assert raster.stats["meshes_skinned"] > 0
    assert_results_same(raster, compute, "crowd")
