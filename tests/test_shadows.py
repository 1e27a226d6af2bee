"""Shadow maps (docs/design.md, Shadow maps), checked against geometry: a ray cast in
numpy from every plane pixel to the light says where the shadow must be, and the closed
form says how bright the rest is. Top-down orthographic views map pixels to plane points
exactly."""
import math

import numpy as np
import pytest

import calibration
import shadow_scenes as ss
from lantern.engine import RenderSettings, render_stage
from lantern.engine.bounces import DIRECT

BOX_LO, BOX_HI = np.array([-0.5, -0.5, 0.0]), np.array([0.5, 0.5, 1.0])


def top_down_camera(stage, width_m, aspect=1.0):
    ss.add_camera(stage, eye=(0, 0, 20), target=(0, 0, 0), aspect=aspect, far=100.0,
                  ortho_width=width_m, up=(0, 1, 0), near=0.1)


def plane_points(w, h, width_m):
    """World points on z = 0 under each pixel centre (row 0 = +Y) of a top-down view."""
    height_m = width_m * h / w
    x = ((np.arange(w) + 0.5) / w - 0.5) * width_m
    y = (0.5 - (np.arange(h) + 0.5) / h) * height_m
    X, Y = np.meshgrid(x, y)
    return np.stack([X, Y, np.zeros_like(X)], axis=-1)


def segment_hits_box(points, targets, lo=BOX_LO, hi=BOX_HI):
    """Does the segment point -> target cross the box (slab test)? targets broadcast."""
    d = targets - points
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - points) / d, (hi - points) / d
    tmin = np.nanmax(np.minimum(t0, t1), axis=-1)
    tmax = np.nanmin(np.maximum(t0, t1), axis=-1)
    return (tmax >= np.maximum(tmin, 1e-6)) & (tmin <= 1.0)


def near_an_edge(mask, px):
    """Pixels within px of a change in `mask` (shadow boundaries are filtered)."""
    out = np.zeros_like(mask)
    for dy in range(-px, px + 1):
        for dx in range(-px, px + 1):
            out |= np.roll(np.roll(mask, dy, 0), dx, 1) != mask
    return out


def render(stage, w, h, preset="medium", **settings):
    # Pixel-exact checks of light and shadow: no anti-aliasing blends edges into them.
    result = render_stage(stage, RenderSettings(width=w, height=h, preset=preset, fxaa=False,
                                                supersample=1, **settings))
    assert np.isfinite(result.rgba).all()
    return result


def test_point_shadow_is_continuous_across_cube_faces():
    """The box's shadow from a point light 2 m up spans several cube faces (the face
    boundaries on the plane are the lines |x| = 2 and |y| = 2 through the light's foot):
    away from the shadow's own edge, every pixel is exactly lit or exactly dark."""
    w = h = 96
    width = 12.0
    light_pos = np.array([-2.5, -2.2, 2.0])
    stage = ss.new_stage()
    ss.add_box(stage, center=(0, 0, 0.5))
    ss.add_light(stage, "point", pos=tuple(light_pos), power=1000.0, radius=0.0)
    top_down_camera(stage, width)
    image = render(stage, w, h).rgba[..., 0]

    p = plane_points(w, h, width)
    on_box = np.all((p[..., :2] >= BOX_LO[:2]) & (p[..., :2] <= BOX_HI[:2]), axis=-1)
    shadowed = segment_hits_box(p, light_pos) & ~on_box
    d = light_pos - p
    d2 = np.sum(d * d, axis=-1)
    lit = 1000.0 / (4 * math.pi) * (d[..., 2] / np.sqrt(d2)) / d2 / math.pi
    expected = np.where(shadowed, 0.0, lit)
    check = ~on_box & ~near_an_edge(shadowed | on_box, 2)
    rel = np.abs(image - expected)[check] / lit[check]
    # The cube face a direction falls on is its major axis, with sign (as a cube map).
    directions = p[shadowed] - light_pos
    major = np.argmax(np.abs(directions), axis=1)
    faces = {(int(a), int(np.sign(directions[i, a]))) for i, a in enumerate(major)}
    assert shadowed.sum() > 200 and len(faces) > 1, faces
    assert rel.max() < 0.02, f"worst {rel.max():.3f} at {np.argwhere(check)[rel.argmax()]}"


def test_spot_shadow_is_confined_to_the_cone():
    w = h = 96
    width = 8.0
    pos = np.array([-1.8, 0.0, 3.0])
    stage = ss.new_stage()
    ss.add_box(stage, center=(0, 0, 0.5))
    ss.add_light(stage, "spot", pos=tuple(pos), aim=(0.2, 0.0, 0.0), power=1000.0, cone=35.0)
    top_down_camera(stage, width)
    image = render(stage, w, h).rgba[..., 0]

    p = plane_points(w, h, width)
    axis = np.array([0.2, 0.0, 0.0]) - pos
    axis /= np.linalg.norm(axis)
    to_p = p - pos
    cos_phi = (to_p @ axis) / np.linalg.norm(to_p, axis=-1)
    inside = cos_phi > math.cos(math.radians(35.0))
    on_box = np.all((p[..., :2] >= BOX_LO[:2]) & (p[..., :2] <= BOX_HI[:2]), axis=-1)
    shadowed = segment_hits_box(p, pos) & ~on_box
    assert np.all(image[~inside & ~on_box & ~near_an_edge(inside, 1)] == 0.0), "light outside the cone"
    d2 = np.sum(to_p * to_p, axis=-1)
    lit = 1000.0 / (4 * math.pi) * (-to_p[..., 2] / np.sqrt(d2)) / d2 / math.pi
    dark = inside & shadowed & ~near_an_edge(shadowed | on_box | ~inside, 2)
    bright = inside & ~shadowed & ~on_box & ~near_an_edge(shadowed | on_box | ~inside, 2)
    assert dark.sum() > 50 and bright.sum() > 200
    assert np.all(image[dark] < 0.02 * lit[dark])
    assert np.abs(image[bright] / lit[bright] - 1).max() < 0.02


def test_contact_shadow_has_no_gap_at_640x360():
    """A hard sun shadow starts at the box's foot: at most 2 lit pixels between the box
    and its shadow (no peter-panning from the bias)."""
    w, h, width = 640, 360, 6.0
    stage = ss.new_stage()
    ss.add_box(stage, center=(0, 0, 0.5))
    # A red top tells the box from the plane in the image.
    from pxr import Sdf, UsdShade
    red = UsdShade.Material.Define(stage, "/root/_materials/red")
    shader = UsdShade.Shader.Define(stage, "/root/_materials/red/surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((1, 0, 0))
    shader.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    red.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/root/box")).Bind(red)
    direction = np.array([math.sin(math.radians(50)), 0.0, -math.cos(math.radians(50))])  # towards +X
    ss.add_light(stage, "sun", dir=tuple(direction), strength=3.0, angle=0.0)
    top_down_camera(stage, width, aspect=w / h)
    rgba = render(stage, w, h).rgba
    gaps = []
    for row in range(h // 2 - 20, h // 2 + 21, 5):  # rows through the box's middle
        r, g = rgba[row, :, 0], rgba[row, :, 1]
        box = np.flatnonzero((r > 0.05) & (g < 0.01 * r))
        assert len(box), row
        edge = box.max()                   # the box's side away from the sun (+X)
        after = g[edge + 1:]
        dark = np.flatnonzero(after < 0.05 * after.max())
        assert len(dark), "no shadow beside the box"
        gaps.append(int(dark[0]))          # lit plane pixels between box and shadow
    print(f"contact gaps (px): {gaps}")
    assert max(gaps) <= 2, gaps


@pytest.mark.parametrize("kind, spec", [
    ("sun", dict(dir=(-math.sin(math.radians(85)), 0.0, -math.cos(math.radians(85))), strength=3.0)),
    ("spot", dict(pos=(-6.0, 0.0, 0.6), aim=(0.0, 0.0, 0.0), power=1000.0, cone=40.0)),
])
def test_no_self_shadowing_at_grazing_angles(kind, spec):
    """An empty plane lit at a grazing angle is the same with and without shadows."""
    w = h = 64
    images = []
    for shadow in (False, True):
        stage = ss.new_stage()
        ss.add_light(stage, kind, shadow=shadow, **spec)
        top_down_camera(stage, 8.0)
        images.append(render(stage, w, h).rgba[..., 0])
    off, on = images
    lit = off > 0.02 * off.max()
    assert lit.sum() > 0.3 * w * h
    assert np.abs(on[lit] / off[lit] - 1).max() < 0.01


@pytest.mark.parametrize("kind", sorted(calibration.LIGHTS))
def test_calibration_with_shadows_on(kind):
    """The light calibration (tests/calibration.py) with Cast Shadow on: mean error ≤ 0.5% in the lit area."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    calibration.build_scene(kind)
    bpy.data.lights[kind].use_shadow = True
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    # The closed form is direct light: the exported scene's bounces are left out.
    result = render(stage, calibration.SIZE, calibration.SIZE, bounces=DIRECT)
    assert result.stats["shadow_maps"] == 1
    reference = calibration.closed_form_radiance(kind)
    mask = reference > 0.05 * reference.max()
    rel = np.abs(result.rgba[..., 0][mask] - reference[mask]) / reference[mask]
    print(f"{kind} with shadows: mean {rel.mean():.5f}, max {rel.max():.5f}")
    assert rel.mean() <= 0.005 and rel.max() <= 0.02


@pytest.mark.parametrize("max_gl", ["45", "33"])
def test_a_shadow_tile_draws_only_the_casters_in_its_frustum(monkeypatch, max_gl):
    """A point light's six faces: boxes a and c lie in its +x face only, b in -x only,
    the plane below in the four side faces and -z. So 8 caster draws, not 6 x 4, with
    the +x face's commands in two runs (a; c and the plane: b lies between them in
    prim-path order). The image is the same as with every caster in every face, on
    the multi-draw path and GL 3.3's."""
    monkeypatch.setenv("LANTERN_MAX_GL", max_gl)
    stage = ss.new_stage()
    ss.add_box(stage, center=(2.5, 0.0, 1.5), size=0.5, name="a")
    ss.add_box(stage, center=(-2.5, 0.0, 1.5), size=0.5, name="b")
    ss.add_box(stage, center=(2.8, 1.2, 1.5), size=0.5, name="c")
    ss.add_light(stage, "point", pos=(0.0, 0.0, 3.0), power=1000.0, radius=0.0)
    top_down_camera(stage, 12.0)
    culled = render(stage, 64, 64, bounces=DIRECT)
    import lantern.engine.gpu.passes.shadows as shadows
    monkeypatch.setattr(shadows, "tile_sees", lambda sm, i, lo, hi: np.ones(len(lo), bool))
    every = render(stage, 64, 64, bounces=DIRECT)
    assert culled.stats["shadow_passes"] == every.stats["shadow_passes"] == 6
    assert (culled.stats["shadow_draws"], every.stats["shadow_draws"]) == (8, 24)
    p = plane_points(64, 64, 12.0)
    behind_a = (p[..., 0] > 4.2) & (p[..., 0] < 5.2) & (np.abs(p[..., 1]) < 0.1)
    assert culled.rgba[..., 0][behind_a].max() == 0.0, "box a cast no shadow"
    np.testing.assert_array_equal(culled.rgba, every.rgba)


def test_an_area_lights_exit_layer_draws_only_the_casters_in_each_tile(monkeypatch):
    """The exit layer (the casters peeled once more, passes/shadow_exits.py) leaves
    out, tile by tile, the casters its map's own depth leaves out: the same boxes as
    above under a rect light, 8 draws a layer and not 24, and the same image."""
    stage = ss.new_stage()
    ss.add_box(stage, center=(2.5, 0.0, 1.5), size=0.5, name="a")
    ss.add_box(stage, center=(-2.5, 0.0, 1.5), size=0.5, name="b")
    ss.add_box(stage, center=(2.8, 1.2, 1.5), size=0.5, name="c")
    ss.add_light(stage, "area", pos=(0.0, 0.0, 3.0), aim=(0.0, 0.0, 0.0), size=0.2,
                 power=1000.0)
    top_down_camera(stage, 12.0)
    culled = render(stage, 64, 64, bounces=DIRECT)
    import lantern.engine.gpu.passes.shadows as shadows
    import lantern.engine.gpu.passes.shadow_exits as exits
    for module in (shadows, exits):
        monkeypatch.setattr(module, "tile_sees", lambda sm, i, lo, hi: np.ones(len(lo), bool))
    every = render(stage, 64, 64, bounces=DIRECT)
    assert culled.stats["shadow_passes"] == every.stats["shadow_passes"] == 6
    assert (culled.stats["shadow_draws"], every.stats["shadow_draws"]) == (2 * 8, 2 * 24)
    np.testing.assert_array_equal(culled.rgba, every.rgba)


def test_lights_that_cast_no_shadow_get_no_shadow_pass():
    stage = ss.new_stage()
    ss.add_box(stage, center=(0, 0, 0.5))
    ss.add_light(stage, "point", shadow=False, pos=(-2.0, 0.0, 2.0), power=1000.0)
    top_down_camera(stage, 8.0)
    result = render(stage, 48, 48)
    assert result.stats["shadow_maps"] == 0 and result.stats["shadow_passes"] == 0
    p = plane_points(48, 48, 8.0)
    behind = (p[..., 0] > 0.8) & (p[..., 0] < 1.5) & (np.abs(p[..., 1]) < 0.3)
    assert result.rgba[..., 0][behind].min() > 0.0, "a non-casting light left a shadow"


def test_no_nan_or_inf_with_shadows_at_extremes():
    stage = ss.new_stage()
    ss.add_box(stage, center=(0, 0, 0.5))
    ss.add_light(stage, "point", pos=(0.0, 0.0, 1.0), power=1000.0, radius=0.0)  # on the box
    ss.add_light(stage, "spot", pos=(2.0, 0.0, 0.0), aim=(2.0, 0.0, -1.0), power=1e6)
    top_down_camera(stage, 8.0)
    for preset in ("low", "ultra"):
        rgba = render(stage, 48, 48, preset).rgba
        assert np.isfinite(rgba).all()
