"""Contact rays (docs/rendering.md, "Shadow seams"): in a frame that bounces light, a short
ray from each receiver towards a sun decides, from the triangles
themselves, the stretch where the shadow map's bias and filter let light through where
an occluder meets its receiver. A frame lit directly stays as it was."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

import transparency_scenes as T
from lantern.engine import RenderSettings, Session, render_stage
from lantern.engine.bounces import DIRECT, Bounces
from test_irradiance_field import sealed_room_stage

SUN_RADIANCE = 0.8 * 4.0 / np.pi     # a white wall of the sealed room in its sun


def with_sun_angle(stage, angle):
    """`stage` with its one sun's angular diameter set to `angle` degrees: a sun with a
    size runs the blocker search, where the ray is left out on open ground (the map
    showing nothing in front of the receiver's own plane: shaders/shadow_lookup.glsl
    behind_own_plane)."""
    sun = next(p for p in stage.Traverse() if p.IsA(UsdLux.DistantLight))
    UsdLux.DistantLight(sun).GetAngleAttr().Set(float(angle))
    return stage


@pytest.mark.parametrize("angle", [0.0, 0.2, 2.0])
def test_a_sealed_room_under_the_sun_gets_no_direct_light_inside(angle):
    # Six zero-thickness walls meeting at seams: without contact rays the seams let the
    # sun through as dots (0.55 of a sunlit wall at this size, 0.22 at the field test's
    # 48 x 32: tests/test_irradiance_field.py). The direct light's render pass alone:
    # the field's own leak at this size is that test's. A sun with a size (2 degrees:
    # the demo's) leaves the ray out where the map shows open ground, not at the seams:
    # at 0.2 degrees the blocker search is about a texel wide and finds no blocker at
    # the seams, where leaving the ray out wherever it finds none lets 0.81 through.
    with Session(with_sun_angle(sealed_room_stage(), angle),
                 RenderSettings(width=160, height=120, bounces=Bounces(),
                                passes=frozenset({"DiffDir"}))) as s:
        direct = s.render().passes["DiffDir"][..., :3]
    assert direct.max() < 1e-4 * SUN_RADIANCE


def test_a_frame_lit_directly_has_no_contact_rays():
    # Bounces 0 is the image as it was: the map alone decides (its seams still leak).
    with Session(sealed_room_stage(), RenderSettings(width=160, height=120,
                                                     bounces=DIRECT)) as s:
        result = s.render()
    assert "field_updates" not in result.stats or result.stats["field_updates"] == 0
    assert result.rgba[..., :3].max() > 0.05 * SUN_RADIANCE


def pane_stage(glass: bool):
    """A white floor, and a 2 x 1 m pane standing on it at x = 0 (zero thickness), a
    sharp sun at 45 degrees from -x behind it: the pane's shadow covers x in (0, 1).
    Seen from above by an orthographic camera 1.6 m wide centred on (0.5, 0)."""
    stage = T._stage()
    white = T.material(stage, "white", diffuse=(0.8, 0.8, 0.8))
    T.quad(stage, "/root/floor", (-4, 4), (-4, 4), 0.0, white)
    pane = T.material(stage, "pane", diffuse=(1.0, 1.0, 1.0), opacity=0.0 if glass else 1.0)
    if glass:
        UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/pane/surface")).GetInput(
            "ior").Set(1.5)
        pane.GetPrim().CreateAttribute("lantern:transmission", Sdf.ValueTypeNames.Float,
                                       custom=True).Set(1.0)
    mesh = UsdGeom.Mesh.Define(stage, "/root/pane")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([Gf.Vec3f(0, -1, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(0, 1, 1),
                           Gf.Vec3f(0, -1, 1)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateDoubleSidedAttr(True)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(pane)
    sun = UsdLux.DistantLight.Define(stage, "/root/sun")
    sun.CreateIntensityAttr(3.0)
    sun.CreateAngleAttr(0.0)
    UsdLux.ShadowAPI.Apply(sun.GetPrim()).CreateShadowEnableAttr(True)
    d = np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, 0, 0), Gf.Vec3d(*d), Gf.Vec3d(0, 0, 1))
    sun.AddTransformOp().Set(m.GetInverse())
    T.camera(stage, (0.5, 0.0, 10.0), (0.5, 0.0, 0.0), up=(0, 1, 0), ortho_width=1.6,
             aspect=1.0)
    return stage


def strip(image, x0, x1):
    """Mean colour of the floor over x in (x0, x1), |y| < 0.4, in pane_stage's view."""
    return T.floor_region(image, (x0, x1), (-0.4, 0.4), centre=(0.5, 0.0), width=1.6)[:3]


def test_an_opaque_pane_shadows_the_floor_up_to_where_it_stands():
    # One sample a pixel: the first centimetre is one pixel, which a supersampled
    # still's pixel filter would mix with the lit side's.
    result = render_stage(pane_stage(glass=False), RenderSettings(
        width=160, height=160, bounces=Bounces(), passes=frozenset({"DiffDir"}),
        supersample=1))
    direct = result.passes["DiffDir"]
    lit, far = strip(direct, -0.25, -0.05), strip(direct, 0.3, 0.7)
    near = strip(direct, 0.0, 0.01)
    # The sun's light on the first centimetre behind the pane's foot is none, as further
    # in; the map alone let 7% of it through there.
    assert lit.mean() > 0.3
    assert far.mean() < 1e-4 * lit.mean()
    assert near.mean() <= far.mean()


def test_glass_lets_its_share_through_up_to_where_it_stands():
    # Contact rays count opaque surfaces only: a pane of glass casts through its map's
    # tested opacity (its share of the sun), right up to the seam, as further in.
    image = render_stage(pane_stage(glass=True), RenderSettings(
        width=160, height=160, bounces=Bounces())).rgba
    far, near = strip(image, 0.3, 0.7), strip(image, 0.01, 0.04)
    assert far.mean() > 0.3 * strip(image, -0.25, -0.05).mean()     # light came through
    assert near.mean() == pytest.approx(far.mean(), rel=0.15)


def test_both_forms_of_the_light_pass_close_the_seams_alike():
    # The light volumes (raster) and the clustered pass's dispatch per shadowed light
    # (compute) share shadow_lookup.glsl's contact rays.
    images = []
    for form in (dict(compute=False, lighting="volumes"),
                 dict(compute=True, lighting="clustered", light_error=0.0)):
        with Session(sealed_room_stage(), RenderSettings(width=48, height=32, bounces=Bounces(),
                                                         **form)) as s:
            images.append(s.render().rgba[..., :3])
    assert max(image.max() for image in images) < 1e-4 * SUN_RADIANCE
    pane = [render_stage(pane_stage(glass=False), RenderSettings(
        width=64, height=64, bounces=Bounces(), **form)).rgba[..., :3]
        for form in (dict(compute=False, lighting="volumes"),
                     dict(compute=True, lighting="clustered", light_error=0.0))]
    assert np.abs(pane[0] - pane[1]).max() < 1e-4
