"""Bounces come from the scene: Cycles' Light Paths (Max Bounces, Diffuse, Glossy) are
exported on /Render/Settings, read back into the scene record, and a render's settings
override them (docs/stage_contract.md "render settings")."""
import pytest


def test_the_scenes_light_paths_travel_to_the_scene_record(empty_scene):
    import bpy
    from _export_helpers import cube_object, export_current
    from lantern.engine import RenderSettings
    from lantern.engine.bounces import DIRECT, Bounces
    from lantern.engine.usd.stage import StageReader
    cube_object("Cube")
    cycles = empty_scene.cycles
    cycles.max_bounces, cycles.diffuse_bounces, cycles.glossy_bounces = 7, 3, 2
    stage, _ = export_current()
    attrs = stage.GetPrimAtPath("/Render/Settings").GetAttribute
    assert [attrs(n).Get() for n in ("lantern:maxBounces", "lantern:diffuseBounces",
                                     "lantern:glossyBounces")] == [7, 3, 2]
    reader = StageReader(stage)
    reader.sync(None)
    assert reader.scene.bounces == Bounces(7, 3, 2)
    assert RenderSettings().bounces_for(reader.scene) == Bounces(7, 3, 2)
    assert RenderSettings(bounces=DIRECT).bounces_for(reader.scene) == DIRECT

    # An edit of /Render/Settings is read at the next sync.
    attrs("lantern:maxBounces").Set(0)
    reader.sync(None)
    assert reader.scene.bounces == Bounces(0, 3, 2)
    assert reader.scene.bounces.diffuse_bounces == 0


def test_a_stage_that_names_no_bounces_is_lit_directly_and_bad_values_warn():
    from pxr import Sdf, Usd, UsdRender
    from lantern.engine import RenderSettings
    from lantern.engine.bounces import DIRECT, Bounces
    from lantern.engine.usd.stage import StageReader
    stage = Usd.Stage.CreateInMemory()
    reader = StageReader(stage)
    reader.sync(None)
    assert reader.scene.bounces is None
    assert RenderSettings().bounces_for(reader.scene) == DIRECT

    stage = Usd.Stage.CreateInMemory()
    prim = UsdRender.Settings.Define(stage, "/Render/Settings").GetPrim()
    prim.CreateAttribute("lantern:diffuseBounces", Sdf.ValueTypeNames.Int).Set(-1)
    prim.CreateAttribute("lantern:glossyBounces", Sdf.ValueTypeNames.Int).Set(1)
    reader = StageReader(stage)
    reader.sync(None)
    assert reader.scene.bounces == Bounces(glossy=1)
    [line] = reader.scene.warning_list()
    assert "/Render/Settings" in line and "lantern:diffuseBounces" in line and "-1" in line


@pytest.mark.parametrize("bad", [-1, 1.5, True])
def test_bounces_are_whole_numbers(bad):
    from lantern.engine.bounces import Bounces
    with pytest.raises(ValueError, match="bounces"):
        Bounces(total=bad)
