"""The irradiance field (engine/gpu/passes/irradiance.py): the diffuse bounce. Small
stages built with pxr; the field needs compute shaders (GL 4.3)."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

import shadow_scenes
import shot_scenes
from lantern.engine import RenderSettings, Session
from lantern.engine.bounces import DIRECT, Bounces

SIZE = dict(width=48, height=32)


def _material(stage, name, color, emission=(0.0, 0.0, 0.0)):
    mat = UsdShade.Material.Define(stage, f"/root/_materials/{name}")
    sh = UsdShade.Shader.Define(stage, f"/root/_materials/{name}/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*emission))
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)        # no specular lobe
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def _quad(stage, name, corners, mat):
    mesh = UsdGeom.Mesh.Define(stage, f"/root/{name}")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([Gf.Vec3f(*c) for c in corners])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)


def glowing_sphere_stage(albedo, radiance):
    """A closed sphere of `albedo` that glows with `radiance`, the camera at its centre."""
    from pxr import Usd
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    ball = UsdGeom.Sphere.Define(stage, "/root/ball")
    ball.CreateRadiusAttr(2.0)
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(
        _material(stage, "glow", (albedo,) * 3, (radiance,) * 3))
    shadow_scenes.add_camera(stage, eye=(0, 0, 0), target=(1, 0.2, 0.1), aspect=1.5, far=10.0)
    UsdLux.DomeLight.Define(stage, "/root/dark").CreateIntensityAttr(0.0)   # no default rig
    return stage


def _mean(stage, bounces):
    with Session(stage, RenderSettings(**SIZE, bounces=bounces, preset="low")) as s:
        r = s.render()
    return float(r.rgba[..., :3].mean()), r


@pytest.mark.parametrize("n", [1, 2])
def test_inside_a_glowing_sphere_n_bounces_add_up_the_series(n):
    rho, le = 0.4, 2.0
    mean, result = _mean(glowing_sphere_stage(rho, le), Bounces(12, n, 4))
    assert result.stats["field_updates"] == n
    expected = le * sum(rho ** k for k in range(n + 1))
    assert mean == pytest.approx(expected, rel=0.01)


def test_inside_a_glowing_sphere_the_scenes_bounces_tend_to_le_over_one_minus_rho():
    rho, le = 0.4, 2.0
    stage = glowing_sphere_stage(rho, le)
    direct, _ = _mean(stage, DIRECT)
    assert direct == pytest.approx(le, rel=1e-3)       # the emission seen: no bounce
    full, result = _mean(stage, Bounces())             # Cycles' 4 diffuse bounces
    assert result.stats["field_updates"] == 4
    assert full == pytest.approx(le / (1.0 - rho), rel=0.02)


def room_stage(settings_bounces=None):
    """A white box room lit by a point light, with a red wall to bleed: a scene that
    bounces; `settings_bounces` written on /Render/Settings as the exporter writes them."""
    stage = shadow_scenes.new_stage(half=2.0)
    white = _material(stage, "white2", (0.8, 0.8, 0.8))
    red = _material(stage, "red", (0.8, 0.1, 0.1))
    x0, y0, z0, x1, y1, z1 = -2, -2, 0, 2, 2, 2.5
    _quad(stage, "ceiling", [(x0, y0, z1), (x0, y1, z1), (x1, y1, z1), (x1, y0, z1)], white)
    _quad(stage, "wall_xn", [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)], red)
    _quad(stage, "wall_yp", [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)], white)
    shadow_scenes.add_box(stage, center=(0.5, 0.5, 0.5), size=1.0)
    shadow_scenes.add_light(stage, "point", pos=(0.5, -0.5, 2.0), power=300.0, radius=0.05,
                            shadow=False)
    shadow_scenes.add_camera(stage, eye=(1.8, -1.8, 1.4), target=(-1, 1, 0.8), aspect=1.5,
                             far=20.0)
    if settings_bounces is not None:
        prim = stage.DefinePrim("/Render/Settings", "RenderSettings")
        for name, value in zip(("maxBounces", "diffuseBounces", "glossyBounces"),
                               settings_bounces):
            prim.CreateAttribute(f"lantern:{name}", Sdf.ValueTypeNames.Int).Set(value)
    return stage


def test_bounces_zero_is_todays_direct_image():
    with Session(room_stage(), RenderSettings(**SIZE)) as s:       # names no bounces
        today = s.render()
    with Session(room_stage((12, 4, 4)), RenderSettings(**SIZE, bounces=DIRECT)) as s:
        direct = s.render()
    with Session(room_stage((12, 4, 4)), RenderSettings(**SIZE)) as s:
        full = s.render()
    assert today.stats["field_updates"] == direct.stats["field_updates"] == 0
    np.testing.assert_allclose(direct.rgba, today.rgba, rtol=1e-3, atol=1e-4)   # float16
    # The same stage with its bounces lights what the lamp does not reach directly.
    assert full.stats["field_updates"] == 4
    assert full.rgba[..., :3].mean() > 1.2 * today.rgba[..., :3].mean()


def test_a_plane_or_a_cube_alone_does_not_bounce_and_a_box_on_a_plane_does():
    """Light a plane or a convex solid sends leaves it: a plane under a spot light
    (flat, then tilted) and a cube alone, with the scene's bounces, build no field and
    render their direct image (the field's angular blur lit the plane outside the
    spot's cone: HDR-FLIP 0.91 against Cycles at full bounces, whose image there is
    black; the corpus's 01_cube 0.14 against 0.008 lit directly; docs/rendering.md
    "Bounced light"). A box standing on the plane, or a lamp inside the cube, bounces."""
    def stage_with(plane=True, box=False, tilt=0.0, lamp=(0.5, -0.3, 3.0)):
        stage = shadow_scenes.new_stage(half=3.0)
        if plane:
            UsdGeom.Xformable(stage.GetPrimAtPath("/root/plane")).AddRotateXOp().Set(tilt)
        else:
            stage.RemovePrim("/root/plane")
        if box:
            shadow_scenes.add_box(stage)
        shadow_scenes.add_light(stage, "spot", pos=lamp, aim=(lamp[0], lamp[1], 0.0),
                                cone=20.0, power=300.0)
        shadow_scenes.add_camera(stage, eye=(0, -6, 4), target=(0, 0, 0), far=30.0)
        return stage
    full = RenderSettings(**SIZE, bounces=Bounces())
    for kw in (dict(), dict(tilt=30.0), dict(plane=False, box=True)):
        with Session(stage_with(**kw), full) as s:
            alone = s.render()
        with Session(stage_with(**kw), RenderSettings(**SIZE, bounces=DIRECT)) as s:
            direct = s.render()
        assert alone.stats["field_updates"] == 0, kw
        np.testing.assert_array_equal(alone.rgba, direct.rgba)
    for kw in (dict(box=True), dict(plane=False, box=True, lamp=(0.1, 0.1, 0.6))):
        with Session(stage_with(**kw), full) as s:
            assert s.render().stats["field_updates"] == 4, kw


def test_a_session_asks_again_whether_its_surfaces_light_each_other_after_an_edit():
    """The pass keeps its answer between frames (comparing every face with every point
    each frame cost the steady frame) and asks again once the geometry changed: a plane
    alone builds no field; a box added on it in the same Session does; the box taken
    away, no field again."""
    stage = shadow_scenes.new_stage(half=3.0)
    shadow_scenes.add_light(stage, "spot", pos=(0.5, -0.3, 3.0), aim=(0.5, -0.3, 0.0),
                            cone=20.0, power=300.0)
    shadow_scenes.add_camera(stage, eye=(0, -6, 4), target=(0, 0, 0), far=30.0)
    with Session(stage, RenderSettings(**SIZE, bounces=Bounces())) as s:
        assert s.render().stats["field_updates"] == 0
        shadow_scenes.add_box(stage)
        assert s.render().stats["field_updates"] == 4
        stage.RemovePrim("/root/box")
        assert s.render().stats["field_updates"] == 0


def test_the_field_updates_only_when_what_it_holds_changes():
    stage = room_stage((12, 4, 4))
    with Session(stage, RenderSettings(**SIZE)) as s:
        first = s.render()
        again = s.render()
        assert first.stats["field_updates"] == 4
        assert again.stats["field_updates"] == 0
        np.testing.assert_array_equal(again.rgba, first.rgba)
        light = UsdGeom.Xformable(stage.GetPrimAtPath("/root/point"))
        light.GetOrderedXformOps()[0].Set(Gf.Vec3d(-0.5, 0.5, 2.0))
        moved = s.render()
        assert moved.stats["field_updates"] == 4
        assert not np.allclose(moved.rgba, first.rgba)
        # A sync outside a render (a tool's rays) takes the stage's edits first: the
        # next render still builds the field again.
        light.GetOrderedXformOps()[0].Set(Gf.Vec3d(0.5, -0.5, 2.0))
        s.trace([(0.0, 0.0, 1.0)], [(0.0, 0.0, -1.0)])
        back = s.render()
        assert back.stats["field_updates"] == 4
        np.testing.assert_array_equal(back.rgba, first.rgba)


def test_a_material_edit_updates_the_field_only_when_its_colour_changes():
    stage = room_stage((12, 4, 4))
    surface = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/red/surface"))
    with Session(stage, RenderSettings(**SIZE)) as s:
        assert s.render().stats["field_updates"] == 4
        surface.GetInput("roughness").Set(0.3)            # not what the field holds
        assert s.render().stats["field_updates"] == 0
        surface.GetInput("diffuseColor").Set(Gf.Vec3f(0.1, 0.8, 0.1))
        assert s.render().stats["field_updates"] == 4


def sealed_room_stage():
    """A closed room of six zero-thickness walls meeting at seams, on a white ground that
    reaches far beyond it, under a sun: no opening. The camera inside."""
    stage = shadow_scenes.new_stage(half=12.0)
    white = _material(stage, "white2", (0.8, 0.8, 0.8))
    for name, corners in shot_scenes.room_walls((-2, -2, 0.0), (2, 2, 2.6)).items():
        _quad(stage, name, corners, white)
    shadow_scenes.add_light(stage, "sun", strength=4.0, dir=(-0.7, -0.2, -0.6))
    shadow_scenes.add_camera(stage, eye=(-1.8, -1.7, 1.5), target=(1, 0.6, 0.7), aspect=1.5,
                             far=30.0)
    return stage


@pytest.mark.parametrize("size, preset, diffuse", [
    (SIZE, "medium", 4),
    (dict(width=160, height=120), "medium", 4),
    (dict(width=160, height=120), "low", 1),
    (dict(width=160, height=120), "low", 4),
    (dict(width=320, height=240), "high", 4),
    (dict(width=640, height=480), "medium", 4),
])
def test_the_bounce_does_not_leak_into_a_sealed_room(size, preset, diffuse):
    # Neither the field, its near field nor, in a frame that bounces light, the direct
    # light (contact rays close the shadow maps' seams: tests/test_shadow_seams.py) lets
    # the sun in. At 160 x 120 the floor's corner by the camera lies just inside a wall
    # that a probe outside sees at a grazing angle: one update's one ray about it met
    # that wall 3.7 m away, beyond the point (2.2 m); the texel's nearest hits over all
    # the build's updates meet it nearer (0.19 of a sunlit wall leaked there before).
    # Low with one bounce traces 64 rays a probe in all: a cone that holds about four
    # of them (0.59 of a sunlit wall leaked into a third of the image through texels
    # whose cone held none). At 320 x 240 high and 640 x 480 medium the G-buffer put
    # floor points by the far corner just past a wall, where the contact ray toward the
    # sun met nothing (0.03 and 0.53 of a sunlit wall, spread by the near field): the
    # ray now starts pulled back along the line of sight (shadow_lookup.glsl
    # contact_origin). A still's final gather reads the field at its rays' hits: at low
    # with 4 bounces, 0.1 of a sunlit wall leaked through the update before the last's
    # walls (its cone held three of the four updates' rays), then at the room's far
    # corner, where hits a few centimetres from the ray's start read probes outside
    # beyond the next wall (field_hits.glsl: the read towards the camera too).
    stage = sealed_room_stage()
    sun_radiance = 0.8 * 4.0 / np.pi          # a white wall in the sun
    settings = RenderSettings(**size, preset=preset, bounces=Bounces(12, diffuse, 4))
    with Session(stage, settings) as s:
        full = s.render()
    assert full.stats["field_updates"] == diffuse and full.stats["field_probes"] > 8
    assert full.rgba[..., :3].max() < 1e-4 * sun_radiance


def test_a_textured_surface_bounces_its_maps_mean_colour(tmp_path):
    from lantern.engine.image_io import write_image
    rho, le = 0.4, 2.0
    image = np.full((4, 4, 4), 1.0, np.float32)
    image[:2, :, :3], image[2:, :, :3] = 0.2, 0.6            # mean 0.4
    write_image(str(tmp_path / "albedo.exr"), image)
    stage = glowing_sphere_stage(0.9, le)                    # 0.9: the unbound value
    root = "/root/_materials/glow"
    reader = UsdShade.Shader.Define(stage, f"{root}/uv")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    tex = UsdShade.Shader.Define(stage, f"{root}/tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tmp_path / "albedo.exr"))
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(),
                                                                      "result")
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    surface = UsdShade.Shader(stage.GetPrimAtPath(f"{root}/surface"))
    surface.GetInput("diffuseColor").ConnectToSource(tex.ConnectableAPI(), "rgb")
    # A roughness map too (no specular lobe at ior 1: it changes nothing seen): its
    # sampler sits on a texture unit the field shares, as material maps do.
    surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).ConnectToSource(
        tex.ConnectableAPI(), "r")
    one, _ = _mean(stage, Bounces(12, 1, 4))
    two, _ = _mean(stage, Bounces(12, 2, 4))
    # The second bounce is the first's light off the walls again: x the map's mean.
    assert (two - le) / (one - le) == pytest.approx(1.0 + rho, rel=0.02)


def test_without_compute_shaders_the_scene_is_lit_directly_with_one_warning():
    stage = room_stage((12, 4, 4))
    with Session(stage, RenderSettings(**SIZE)) as s:
        from lantern.engine.gpu.context import run_gl
        run_gl(lambda gl: setattr(s._renderer.irradiance, "compute", False))
        result = s.render()
    assert result.stats["field_updates"] == 0
    lines = [w for w in result.warnings if "compute shaders" in w]
    assert len(lines) == 1 and "lit directly" in lines[0]
    with Session(stage, RenderSettings(**SIZE, bounces=DIRECT)) as s:
        direct = s.render()
    np.testing.assert_array_equal(result.rgba, direct.rgba)


def test_a_lamp_inside_a_sphere_bounces_its_light_by_the_series():
    # A point light at the centre lights the sphere evenly: each bounce adds rho times
    # the last, through the hits' shadow rays and the light table as the pixels see it.
    rho = 0.5
    stage = glowing_sphere_stage(rho, 0.0)
    shadow_scenes.add_light(stage, "point", pos=(0, 0, 0), power=100.0, radius=0.01,
                            shadow=False)
    direct, _ = _mean(stage, DIRECT)
    full, _ = _mean(stage, Bounces())
    assert direct > 0.1
    assert full / direct == pytest.approx(sum(rho ** k for k in range(5)), rel=0.01)


def pane_stage(tint=None):
    """A white floor (albedo 1) in a 2 x 2 x 1.5 m room of black walls open to a blue sky
    (no lamp), the camera looking down; with `tint`, a glass roof 5 cm thick (IOR 1.5, of
    that colour) closes it."""
    stage = shadow_scenes.new_stage(half=1.0)
    UsdLux.DomeLight.Define(stage, "/root/sky").CreateColorAttr(Gf.Vec3f(0.2, 0.35, 0.8))
    black = _material(stage, "black", (0.0, 0.0, 0.0))
    for name, corners in shot_scenes.room_walls((-1, -1, 0), (1, 1, 1.5)).items():
        if name.startswith("Wall"):
            _quad(stage, name, corners, black)
    if tint is not None:
        glass = _material(stage, "glass", tint)
        surface = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/glass/surface"))
        surface.GetInput("ior").Set(1.5)
        surface.GetInput("roughness").Set(0.0)
        glass.GetPrim().CreateAttribute("lantern:transmission", Sdf.ValueTypeNames.Float,
                                        custom=True).Set(1.0)
        pane = UsdGeom.Cube.Define(stage, "/root/Roof")
        pane.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 1.525))
        pane.AddScaleOp().Set(Gf.Vec3f(1.0, 1.0, 0.025))
        UsdShade.MaterialBindingAPI.Apply(pane.GetPrim()).Bind(glass)
    shadow_scenes.add_camera(stage, eye=(0, -0.05, 1.2), target=(0, 0, 0), aspect=1.5)
    return stage


def test_the_field_under_a_glass_roof_lets_the_sky_through_tinted():
    # The floor's light is the sky's through the opening, by the field (black walls: no
    # bounce). A glass roof lets it through: a face's Fresnel transmittance twice, 0.915
    # within the 34 degrees the opening spans from the floor's centre; a tinted roof takes
    # its colour at each face (tint^2). Until glass passed the field's rays it was a
    # black lid. Medium: low's coarser grid leaves dark specks on this floor.
    def floor(stage):
        with Session(stage, RenderSettings(**SIZE, bounces=Bounces(), preset="medium")) as s:
            result = s.render()
        assert result.stats["field_updates"] == 4
        return result.rgba[8:24, 12:36, :3].mean(axis=(0, 1))
    bare = floor(pane_stage())
    clear = floor(pane_stage(tint=(1.0, 1.0, 1.0)))
    tinted = floor(pane_stage(tint=(1.0, 0.6, 0.3)))
    assert (clear / bare) == pytest.approx([0.915] * 3, abs=0.05), clear / bare
    assert (tinted / clear) == pytest.approx([1.0, 0.36, 0.09], rel=0.1), tinted / clear


def test_each_probes_tile_border_repeats_its_maps_opposite_edge():
    """The blend makes a probe's 8 x 8 texels once and writes each edge texel again to
    the tile's border, mirrored (shaders/irradiance_blend.comp places): the border is
    what bilinear reads across an octahedral map's edge need. Checked on every probe's
    irradiance and distance tiles against the mirror image of its interior."""
    from lantern.engine.gpu.context import run_gl
    from lantern.engine.gpu.passes.irradiance import TEXELS, TILE, TILES_PER_LINE
    with Session(room_stage((12, 4, 4)), RenderSettings(**SIZE, preset="low")) as s:
        s.render()
        field = s._renderer.irradiance.field

        def read(tex):
            w, h = tex.size
            return np.frombuffer(tex.read(), np.float32).reshape(h, w, 4)
        maps = run_gl(lambda gl: [read(field.irradiance), read(field.distance)])
        probes = sum(g.probes for g in field.grids)
    n = TEXELS
    for atlas in maps:
        for probe in range(probes):
            y0, x0 = (probe // TILES_PER_LINE) * TILE, (probe % TILES_PER_LINE) * TILE
            tile = atlas[y0:y0 + TILE, x0:x0 + TILE]       # [y, x]
            inner = tile[1:n + 1, 1:n + 1]
            assert np.abs(inner).sum() > 0, probe
            np.testing.assert_array_equal(tile[1:n + 1, 0], inner[::-1, 0])      # x = 0
            np.testing.assert_array_equal(tile[1:n + 1, n + 1], inner[::-1, -1])  # x = N + 1
            np.testing.assert_array_equal(tile[0, 1:n + 1], inner[0, ::-1])       # y = 0
            np.testing.assert_array_equal(tile[n + 1, 1:n + 1], inner[-1, ::-1])  # y = N + 1
            for (ty, tx), (sy, sx) in (((0, 0), (n, n)), ((0, n + 1), (n, 1)),
                                       ((n + 1, 0), (1, n)), ((n + 1, n + 1), (1, 1))):
                np.testing.assert_array_equal(tile[ty, tx], tile[sy, sx])
