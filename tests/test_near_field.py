"""The near field of the diffuse bounce (engine/gpu/passes/near_field.py): the AO pass's
horizon search, run within half a probe spacing over the lit frame, gathers the light of
the surfaces that hide a pixel's hemisphere in place of the irradiance field's over
those directions. Small stages built with pxr; the field needs compute shaders."""
import numpy as np
import pytest
from pxr import Sdf, UsdLux

import shadow_scenes
from lantern.engine import RenderSettings, Session
from lantern.engine.bounces import DIRECT, Bounces
from lantern.engine.gpu.passes import near_field
from test_irradiance_field import _material, _quad

SIZE = dict(width=96, height=64)


def render(stage, near=True, **settings):
    """The stage's render at medium with Cycles' default bounces (or `settings`'),
    with the screen's near field (as a viewport's frames take it: no final gather) or,
    `near` False, without it (the field alone)."""
    settings = {**SIZE, "preset": "medium", "bounces": Bounces(), "final_gather": False,
                **settings}
    with pytest.MonkeyPatch.context() as m:
        if not near:
            m.setattr(near_field.NearFieldPass, "needed", lambda self, frame: False)
        with Session(stage, RenderSettings(**settings)) as s:
            return s.render()


def red_wall_stage():
    """A white block 4 cm from a red wall on a white floor, lit by a sun that lights the
    wall, the block's faces and the floor; the camera sees the block's front face, its
    side towards the wall hidden. The field's probes are 0.53 apart at medium, 1.14 at
    low: the gap is a few hundredths of their spacing."""
    stage = shadow_scenes.new_stage(half=2.0)
    red = _material(stage, "red", (0.8, 0.05, 0.05))
    _quad(stage, "wall", [(0, -2, 0), (0, 2, 0), (0, 2, 2), (0, -2, 2)], red)
    shadow_scenes.add_box(stage, center=(0.29, 0.0, 0.25), size=0.5)
    shadow_scenes.add_light(stage, "sun", aim=(-0.5, 0.4, -1.0), pos=(2, -2, 3),
                            strength=3.0, shadow=True)
    shadow_scenes.add_camera(stage, eye=(1.6, -2.2, 1.2), target=(0.2, 0.0, 0.2),
                             aspect=1.5, far=20.0)
    UsdLux.DomeLight.Define(stage, "/root/dark").CreateIntensityAttr(0.0)
    return stage


def front_face(result):
    """The pixels of the block's face towards the camera (normal -y), nearest the wall
    first: (mask of that face, its left third)."""
    normal = result.passes["Normal"]
    face = normal[..., 1] < -0.9
    cols = np.nonzero(face.any(axis=0))[0]
    left = face.copy()
    left[:, cols[0] + (cols[-1] - cols[0] + 1) // 3:] = False
    return face, left


def test_a_red_wall_bleeds_onto_a_white_block_beside_it():
    """The block's face beside the red wall gains red from the wall, which the field's
    probes (at low 1.14 apart, the gap 0.04) hold too coarsely: more red than green and
    blue gained, the more the nearer the wall. (Medium's probes, 0.53 apart, hold more
    of it: the near field adds 2.4% there, 4.8% at low.)"""
    stage = red_wall_stage()
    passes = frozenset({"Normal"})
    near, far = (render(stage, passes=passes, preset="low"),
                 render(stage, near=False, passes=passes, preset="low"))
    assert "near_field" in near.stats["passes"] and "near_field" not in far.stats["passes"]
    face, left = front_face(near)
    gained = near.rgba[..., :3].astype(np.float64) - far.rgba[..., :3]
    before = far.rgba[..., 0][left].mean()
    # The floor's and the wall's light both come nearer than the probes hold; the red
    # beyond the grey they add is the wall's.
    red, green, blue = gained[left].mean(axis=0)
    bleed = red - max(green, blue)
    bleed_face = gained[face][:, 0].mean() - gained[face][:, 1:].mean(axis=0).max()
    print(f"block's face beside the wall: red {before:.4f} + {red:.4f}, green {green:+.4f}, "
          f"blue {blue:+.4f}; red beyond them {bleed:.4f} (the whole face {bleed_face:.4f})")
    assert bleed > 0.03 * before
    assert bleed > bleed_face > 0.0


def test_direct_mode_has_no_near_field_and_the_same_occlusion():
    """Without bounces no near field runs, and the AO pass's occlusion is the same bit
    for bit with and without the field (its search variant is compiled apart)."""
    stage = red_wall_stage()
    UsdLux.DomeLight.Get(stage, "/root/dark").CreateIntensityAttr(1.0)
    passes = frozenset({"AO"})
    direct, full = render(stage, passes=passes, bounces=DIRECT), render(stage, passes=passes)
    assert "near_field" not in direct.stats["passes"]
    assert "near_field" in full.stats["passes"]
    assert np.array_equal(direct.passes["AO"], full.passes["AO"])


def test_a_flat_open_plane_under_the_dome_gains_nothing():
    """Nothing hides any direction of a flat plane open to the dome: the near field
    changes no pixel (the field's light is left as it was, bit for bit). A box under
    the plane, out of view, makes the scene one that bounces (a plane alone builds no
    field: engine/bounces.py)."""
    stage = shadow_scenes.new_stage(half=2.0)
    shadow_scenes.add_box(stage, center=(0.0, 0.0, -3.0), size=0.5)
    shadow_scenes.add_camera(stage, eye=(1.5, -1.5, 1.0), target=(0, 0, 0), aspect=1.5,
                             far=20.0)
    UsdLux.DomeLight.Define(stage, "/root/sky").CreateIntensityAttr(1.0)
    near, far = render(stage), render(stage, near=False)
    assert "near_field" in near.stats["passes"]
    assert np.array_equal(near.rgba, far.rgba)
    # A still's final gather brings the dome's light by its rays: the white plane (no
    # specular: IOR 1) under a dome of radiance 1 shows 1, within 2%. (The field alone
    # leaves this plane black: every probe of its cells is hidden by the planes of the
    # box's faces below it, docs/status.md "Objects in open space".)
    gathered = render(stage, final_gather=True)
    assert gathered.stats["gather_rays"] > 0
    np.testing.assert_allclose(gathered.rgba[40:, :, :3], 1.0, rtol=0.02)


def test_with_the_field_the_ao_pass_searches_the_specular_occlusion_alone():
    """In a frame whose diffuse light is the field's, nothing reads the diffuse
    occlusion: the AO pass searches only the specular slice, and the image is the one
    the whole search gives, bit for bit (a glossy block under a dome, no glossy bounce:
    its reflections of the dome take the specular occlusion)."""
    from lantern.engine.gpu.passes import ao
    stage = red_wall_stage()
    UsdLux.DomeLight.Get(stage, "/root/dark").CreateIntensityAttr(1.0)
    shiny = _material(stage, "shiny", (0.5, 0.5, 0.5))
    shiny.GetPrim().GetChild("surface").GetAttribute("inputs:ior").Set(1.5)
    shiny.GetPrim().GetChild("surface").GetAttribute("inputs:roughness").Set(0.3)
    from pxr import UsdShade
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/root/box")).Bind(shiny)
    diffuse_only = Bounces(12, 4, 0)
    alone = render(stage, bounces=diffuse_only)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(ao, "diffuse_unused", lambda frame, board: False)
        whole = render(stage, bounces=diffuse_only)
    assert "ao" in alone.stats["passes"] and "reflections" not in alone.stats["passes"]
    assert np.array_equal(alone.rgba, whole.rgba)


@pytest.mark.parametrize("coat", [0.0, 1.0])
def test_with_the_field_and_the_glossy_bounce_the_ao_pass_searches_only_for_a_coat(coat):
    """With the glossy bounce too, the base lobe reflects the scene, not the dome: only
    a coat's dome reflection takes the specular occlusion. Without a coat nothing reads
    the occlusion and the AO pass searches nothing; the image is the one the search
    gives, bit for bit. With one, it searches."""
    from pxr import UsdShade
    from lantern.engine.gpu.passes import ao
    stage = red_wall_stage()
    UsdLux.DomeLight.Get(stage, "/root/dark").CreateIntensityAttr(1.0)
    shiny = _material(stage, "shiny", (0.5, 0.5, 0.5))
    surface = shiny.GetPrim().GetChild("surface")
    surface.GetAttribute("inputs:ior").Set(1.5)
    surface.GetAttribute("inputs:roughness").Set(0.3)
    UsdShade.Shader(surface).CreateInput("clearcoat", Sdf.ValueTypeNames.Float).Set(coat)
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/root/box")).Bind(shiny)
    searches = []
    search_setup = ao.search_setup
    with pytest.MonkeyPatch.context() as m:
        m.setattr(ao, "search_setup", lambda *a: searches.append(1) or search_setup(*a))
        alone = render(stage)
        m.setattr(ao, "occlusion_unused", lambda frame, board: False)
        whole = render(stage)
    assert "reflections" in alone.stats["passes"]
    assert len(searches) == (2 if coat else 1)      # the AO pass's own searches
    assert np.array_equal(alone.rgba, whole.rgba)
