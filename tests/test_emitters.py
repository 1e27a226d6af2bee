"""Meshes whose material emits light other surfaces (engine/emitters.py): an emissive
quad lights a white Lambert plane as a rect light of the same size and power does
(radiance L = intensity / area, the stage contract's "Emission" and "Lights"), within
1%, through both forms of the light pass; the material's emission sampling chooses the
faces that light (none, front, back, both); an edit moves the lights with the mesh."""
import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdShade

from emitter_scenes import CENTRE, FORMS, SIZE, H, W, plane_mask, stage_with
from lantern.engine import RenderSettings, Session, render_stage
from lantern.engine.emitters import polygons
from lantern.engine.usd.stage import StageReader


def render(stage, form, stats=None):
    # Closed forms per pixel centre: one sample a pixel (no supersampling of small stills).
    res = render_stage(stage, RenderSettings(width=W, height=H, supersample=1, **FORMS[form]))
    assert np.isfinite(res.rgba).all()
    if stats is not None:
        stats.update(res.stats, warnings=res.warnings)
    return res.rgba[..., 0]


@pytest.fixture(scope="module")
def rect_images():
    return {form: render(stage_with("rect"), form) for form in FORMS}


@pytest.mark.parametrize("form", sorted(FORMS))
def test_emissive_quad_lights_as_a_rect_light_of_its_size_and_power(form, rect_images):
    rect, quad = rect_images[form], render(stage_with("quad"), form)
    mask = plane_mask() & (rect > 0.02 * rect.max())
    assert mask.sum() > 200
    err = float(np.max(np.abs(quad[mask] - rect[mask]) / rect[mask]))
    print(f"{form}: worst relative difference {err:.2e}")
    assert err < 0.01


@pytest.mark.parametrize("form", sorted(FORMS))
def test_a_panel_of_many_quads_lights_as_one_rect_with_one_shadow_map(form, rect_images):
    """64 polygons, one light, one map: the mesh's polygons share an area light's
    shadow over the box they lie in, here the panel itself, as the rect light's; the
    light volumes draw one volume."""
    stats = {}
    rect, grid = rect_images[form], render(stage_with("quad", cells=8), form, stats)
    mask = plane_mask() & (rect > 0.02 * rect.max())
    err = float(np.max(np.abs(grid[mask] - rect[mask]) / rect[mask]))
    print(f"{form}: 64 quads, worst relative difference {err:.2e}")
    assert err < 0.01
    assert stats["shadow_maps"] == 1 and stats["warnings"] == []
    if form == "volumes":
        assert stats["light_volumes"] == 1


# (emission sampling, the quad's normals along z) -> whether the plane (below) is lit
SIDES = {("none", -1.0): False, ("front", -1.0): True, ("front", 1.0): False,
         ("back", 1.0): True, ("back", -1.0): False, ("both", 1.0): True, ("", 1.0): True}


@pytest.mark.parametrize("sampling,facing", sorted(SIDES))
def test_emission_sampling_chooses_the_faces_that_light(sampling, facing, rect_images):
    quad = render(stage_with("quad", sampling, facing), "volumes")
    mask = plane_mask()
    rect = rect_images["volumes"]
    if SIDES[sampling, facing]:
        lit = mask & (rect > 0.02 * rect.max())
        assert float(np.max(np.abs(quad[lit] - rect[lit]) / rect[lit])) < 0.01
    else:
        assert float(quad[mask].max()) == 0.0


def test_a_moved_emissive_mesh_moves_its_lights_and_nothing_else_is_made():
    stage = stage_with("quad", "front")
    reader = StageReader(stage)
    try:
        reader.sync(None)
        lights = reader.scene.lights
        paths = [p for p in lights if p.startswith("/root/panel")]
        assert len(paths) == 1
        before = lights[paths[0]]
        assert len(before.polygons) == 1           # the quad's two triangles, merged
        assert np.allclose(before.position, CENTRE)
        assert math.isclose(before.width * before.height, SIZE[0] * SIZE[1], rel_tol=1e-6)
        UsdGeom.Xformable(stage.GetPrimAtPath("/root/panel")).GetOrderedXformOps()[0].Set(
            Gf.Vec3d(*(CENTRE + [1.0, 0.0, 0.0])))
        assert reader.sync(None).lights == set(paths)
        assert np.allclose(reader.scene.lights[paths[0]].position, CENTRE + [1, 0, 0])
        # An edit of the plane (it does not emit) touches no light.
        stage.GetPrimAtPath("/root/plane").GetAttribute("doubleSided").Set(True)
        assert reader.sync(None).lights == set()
        # Its material set to light nothing: its light goes.
        stage.GetPrimAtPath("/root/glow").GetAttribute("lantern:emissionSampling").Set("none")
        assert reader.sync(None).lights == set(paths)
        assert not any(p.startswith("/root/panel") for p in reader.scene.lights)
    finally:
        reader.close()


def test_a_scene_without_emission_has_no_emitter_lights():
    reader = StageReader(stage_with("rect"))
    try:
        reader.sync(None)
        assert list(reader.scene.lights) == ["/root/rect"]
    finally:
        reader.close()


def test_a_planar_convex_quad_merges_and_a_bent_one_does_not():
    flat = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    up = np.tile([0.0, 0.0, 1.0], (2, 3, 1))
    merged = polygons(flat, up)
    assert len(merged) == 1 and len(merged[0]) == 4
    assert math.isclose(np.cross(merged[0][1] - merged[0][0], merged[0][2] - merged[0][0])[2], 1.0)
    bent = flat.copy()
    bent[1, 2, 2] = 0.5
    assert [len(p) for p in polygons(bent, up)] == [3, 3]
    down = polygons(flat, -up)                     # normals the other way: wound the other way
    assert np.cross(down[0][1] - down[0][0], down[0][2] - down[0][0])[2] < 0


def test_emission_sampling_is_exported_where_not_auto(empty_scene):
    """Material > Settings > Emission Sampling (material.cycles.emission_sampling):
    lantern:emissionSampling on the Material prim, unauthored for Cycles' Auto, and the
    reader takes it."""
    import bpy
    from _export_helpers import cube_object, export_current
    from lantern.engine.usd.materials import read_material
    for i, sampling in enumerate(("AUTO", "NONE", "FRONT", "BACK", "FRONT_BACK")):
        mat = bpy.data.materials.new(sampling)
        mat.cycles.emission_sampling = sampling
        cube_object(f"C{i}").data.materials.append(mat)
    stage, _ = export_current()
    attr = "lantern:emissionSampling"
    assert not stage.GetPrimAtPath("/root/_materials/AUTO").HasAttribute(attr)
    read = {}
    for sampling in ("NONE", "FRONT", "BACK", "FRONT_BACK"):
        prim = stage.GetPrimAtPath(f"/root/_materials/{sampling}")
        read[sampling] = read_material(UsdShade.Material(prim), Usd.TimeCode.Default(),
                                       []).emission_sampling
    assert read == {"NONE": "none", "FRONT": "front", "BACK": "back", "FRONT_BACK": "both"}


def test_emissive_table_shot_is_as_close_to_cycles_as_four_samples():
    """The table lit only by an emissive panel (tests/shot_scenes.py), direct light,
    at medium: mean HDR-FLIP against Cycles' 1,024-spp reference at or below Cycles'
    own at 4 spp, 0.100 (bench/bench_shots.py, 2026-11-28; before emitters lit, 0.873)."""
    import bpy
    import shot_scenes
    from image_metrics import mean_flip
    from lantern.engine.bounces import DIRECT
    from lantern.engine import read_exr
    from lantern.exporters import stage_from_depsgraph
    shot_scenes.build("emissive_table")
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    width, height = shot_scenes.SIZE
    result = render_stage(stage, RenderSettings(width=width, height=height, preset="medium",
                                                bounces=DIRECT))     # the reference's
    flip = mean_flip(result.rgba, read_exr(str(shot_scenes.reference_path("emissive_table",
                                                                           "direct"))))
    print(f"emissive_table direct: mean HDR-FLIP {flip:.4f}")
    assert flip <= 0.100


def test_a_session_moving_a_many_polygon_emitter_renders_as_a_fresh_read():
    """The light's rows written again in place (its polygon rows span table lines)
    give the image a first read of the edited stage gives."""
    stage = stage_with("quad", cells=9)
    settings = RenderSettings(width=W, height=H, **FORMS["volumes"])
    session = Session(stage, settings)
    try:
        session.render()
        UsdGeom.Xformable(stage.GetPrimAtPath("/root/panel")).GetOrderedXformOps()[0].Set(
            Gf.Vec3d(*(CENTRE + [0.4, -0.2, 0.1])))
        moved = session.render().rgba
    finally:
        session.close()
    fresh = render_stage(stage, settings).rgba
    assert np.abs(moved - fresh).max() <= 1e-6 * np.abs(fresh).max()
    assert np.abs(moved - render(stage_with("quad", cells=9), "volumes")[..., None]).max() > 0


def test_a_textured_emission_lights_with_its_mean(tmp_path):
    """An emission texture's mean times its scale plus its bias (a linear EXR)."""
    from lantern.engine.emitters import radiance
    from lantern.engine.image_io import write_image
    from lantern.engine.scene import Material, TextureRef
    path = str(tmp_path / "glow.exr")
    pixels = np.zeros((2, 2, 4), np.float32)
    pixels[..., 3] = 1.0
    pixels[0, 0, :3] = (4.0, 2.0, 0.0)
    pixels[1, 1, :3] = (0.0, 2.0, 8.0)
    write_image(path, pixels)
    material = Material(name="/glow", emissive=(1.0, 1.0, 1.0), maps={
        "emissiveColor": TextureRef(path, "raw", scale=(3.0, 3.0, 3.0, 1.0),
                                    bias=(0.5, 0.0, 0.0, 0.0))})
    assert np.allclose(radiance(material), [3.0 * 1.0 + 0.5, 3.0 * 1.0, 3.0 * 2.0])
    assert np.allclose(radiance(Material(name="/flat", emissive=(2.0, 1.0, 0.5))), [2, 1, 0.5])


def test_a_textured_emission_lights_each_triangle_with_the_texture_over_it(tmp_path):
    """A triangle inside the texture's bright quarter lights with it, one inside a dark
    quarter with nothing; one covering the whole image with its mean."""
    from lantern.engine.emitters import triangle_radiance
    from lantern.engine.image_io import write_image
    from lantern.engine.scene import Material, TextureRef
    path = str(tmp_path / "quarter.exr")
    pixels = np.zeros((8, 8, 4), np.float32)
    pixels[..., 3] = 1.0
    pixels[:4, :4, :3] = (4.0, 2.0, 1.0)            # rows from the top: the top left
    write_image(path, pixels)
    material = Material(name="/glow", emissive=(1.0, 1.0, 1.0), maps={
        "emissiveColor": TextureRef(path, "raw")})
    small = np.array([[0.05, 0.55], [0.2, 0.55], [0.05, 0.7]])     # u, v up: top left
    whole = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    got = triangle_radiance(material, np.stack([small, small + [0.5, 0.0], whole]))
    assert np.allclose(got[0], [4.0, 2.0, 1.0])
    assert np.allclose(got[1], 0.0)
    assert np.allclose(got[2], [1.0, 0.5, 0.25])


def test_emission_from_a_node_network_is_not_made_a_light_and_says_so():
    """01_principled_material's emission is a texture through a network: its constant
    (0.8 white) would light the scene as a lamp; not a light, one line naming the mesh."""
    import bpy
    import reference_scenes
    from lantern.exporters import stage_from_depsgraph
    import tempfile
    reference_scenes.build("01_principled_material", tempfile.mkdtemp())
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    reader = StageReader(stage)
    reader.sync(None)
    assert not [p for p, light in reader.scene.lights.items() if light.kind == "polygon"]
    lines = [w for w in reader.scene.warning_list() if "node network" in w]
    assert len(lines) == 1 and "TwoCubes" in lines[0], lines


def test_a_mesh_of_more_polygons_than_a_light_holds_is_several_lights_that_light_as_one():
    """289 quads: two lights of polygons that lie together (a shader loops over a
    light's polygons, and llvmpipe ends an invocation's loops after 65,535
    iterations), each with its own map; together as the rect light."""
    from lantern.engine.emitters import CHUNK
    stage = stage_with("quad", cells=17)
    reader = StageReader(stage)
    try:
        reader.sync(None)
        sizes = sorted(len(light.polygons) for light in reader.scene.lights.values())
    finally:
        reader.close()
    assert sizes == [289 - CHUNK, CHUNK]
    stats = {}
    rect, grid = render(stage_with("rect"), "volumes"), render(stage, "volumes", stats)
    mask = plane_mask() & (rect > 0.02 * rect.max())
    assert float(np.max(np.abs(grid[mask] - rect[mask]) / rect[mask])) < 0.01
    assert stats["shadow_maps"] == 2 and stats["light_volumes"] == 2


def test_an_unknown_emission_sampling_is_a_warning_and_auto():
    from lantern.engine.usd.materials import read_material
    stage = stage_with("quad", "sideways")
    warnings = []
    material = read_material(UsdShade.Material(stage.GetPrimAtPath("/root/glow")),
                             Usd.TimeCode.Default(), warnings)
    assert material.emission_sampling == "auto"
    assert warnings == ["/root/glow: lantern:emissionSampling 'sideways' is not one of "
                        "none, auto, front, back, both; using 'auto'"]


def test_a_closed_emissive_mesh_lights_as_its_faces_would_as_rect_lights():
    """An emissive cube (Auto: both faces) above the plane: its one shadow map, from
    its middle, inside it, is not cast into by the cube itself, and its faces' backs,
    which light only its inside, light nothing; so the plane is lit as by five rect
    lights in the places of the faces that see it."""
    from pxr import Gf, Sdf, UsdLux
    import shadow_scenes
    centre, size, L = np.array([0.3, 0.2, 1.0]), 0.4, 20.0
    cube = stage_with("rect")
    cube.RemovePrim("/root/rect")
    box = shadow_scenes.add_box(cube, center=tuple(centre), size=size, name="lamp")
    glow = UsdShade.Material.Define(cube, "/root/glow")
    surface = UsdShade.Shader.Define(cube, "/root/glow/surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(L, L, L))
    glow.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(box.GetPrim()).Bind(glow)
    rects = stage_with("rect")
    rects.RemovePrim("/root/rect")
    # (face centre offset, rotation op, angle): a RectLight emits along its -Z.
    faces = [((0, 0, -1), None, 0.0), ((1, 0, 0), "Y", -90.0), ((-1, 0, 0), "Y", 90.0),
             ((0, 1, 0), "X", 90.0), ((0, -1, 0), "X", -90.0)]
    for i, (offset, axis, angle) in enumerate(faces):
        rect = UsdLux.RectLight.Define(rects, f"/root/face{i}")
        rect.CreateIntensityAttr(L * size * size)
        rect.CreateNormalizeAttr(True)
        rect.CreateWidthAttr(size)
        rect.CreateHeightAttr(size)
        rect.AddTranslateOp().Set(Gf.Vec3d(*(centre + np.asarray(offset) * size / 2)))
        if axis == "X":
            rect.AddRotateXOp().Set(angle)
        elif axis == "Y":
            rect.AddRotateYOp().Set(angle)
    lit, want = render(cube, "volumes"), render(rects, "volumes")
    plane = lit < 0.5 * L                          # not the cube itself
    for shift in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        plane &= np.roll(lit, shift, axis=(0, 1)) < 0.5 * L   # nor its edge
    mask = plane & (want > 0.02 * want[plane].max())
    assert mask.sum() > 500
    err = float(np.max(np.abs(lit[mask] - want[mask]) / want[mask]))
    print(f"closed cube: worst relative difference {err:.2e}")
    assert err < 0.01


@pytest.mark.parametrize("cells", [17, 32])
def test_a_large_panel_lights_as_one_rect_through_its_groups_not_polygon_by_polygon(cells):
    """289 quads (lights of 256 and 33) and 1,024 (four of 256): each light's polygons
    are the leaves of a tree of groups, ordered by the mesh's rows and columns, and a
    group of quads that fills its rect with one radiance is shaded as that rect,
    exactly; so a pixel visits a few nodes of each light, not its hundreds of
    polygons (the steps the clustered pass counts: its compute form, which counts them
    for shadowed lights too), and the plane is lit as by the rect."""
    settings = RenderSettings(width=W, height=H, compute=True, **FORMS["clustered"])
    rect = render_stage(stage_with("rect"), settings).rgba[..., 0]
    res = render_stage(stage_with("quad", cells=cells), settings)
    grid, stats = res.rgba[..., 0], res.stats
    assert res.warnings == []
    mask = plane_mask() & (rect > 0.02 * rect.max())
    err = float(np.max(np.abs(grid[mask] - rect[mask]) / rect[mask]))
    print(f"{cells} x {cells} quads: worst relative difference {err:.2e}, "
          f"{stats['light_tree_steps']} steps over {stats['light_tree_pixels']} pixel-lights")
    assert err < 0.01
    assert stats["light_tree_pixels"] >= mask.sum()
    assert stats["light_tree_steps"] <= 8 * stats["light_tree_pixels"]   # of 256 a light


def _irradiance(quads, colours, p, n, cells=24):
    """The irradiance at p facing n from one-sided quads (corners wound about their
    front) of radiance `colours`, by the midpoint rule over cells x cells parts each."""
    total = np.zeros(3)
    t = (np.arange(cells) + 0.5) / cells
    for q, colour in zip(quads, colours):
        a, b, d = q[0], q[1], q[3]
        x = a + t[:, None, None] * (b - a) + t[None, :, None] * (d - a)
        front = np.cross(b - a, d - a)
        area = np.linalg.norm(front)
        u = x.reshape(-1, 3) - p
        r2 = (u * u).sum(axis=1)
        k = np.maximum(-(u @ front) / area, 0) * np.maximum(u @ n, 0) / r2 ** 2
        total += colour * k.mean() * area
    return total


def test_a_group_of_unlike_polygons_is_within_its_bound_of_them():
    """Groups of a grid's quads of random radiance, some left out: the rect of their
    mean radiance differs from them by no more than the bound the shader tests
    (engine/emitter_groups.py), at points from just past the group to far."""
    from lantern.engine import emitter_groups
    rng = np.random.default_rng(7)
    checked = 0
    for trial in range(12):
        cells = 4
        keep = rng.random(cells * cells) < 0.7
        keep[0] = True
        quads, colours = [], []
        for j in range(cells):
            for i in range(cells):
                if keep[j * cells + i]:
                    o = np.array([i * 0.1, j * 0.07, 0.0])
                    quads.append(np.array([o, o + [0.1, 0, 0], o + [0.1, 0.07, 0], o + [0, 0.07, 0]]))
                    colours.append(rng.uniform(0.2, 2.0, 3))
        # wound about +z: they light upwards
        g = emitter_groups.build(quads, colours, np.zeros(len(quads), bool))
        for _ in range(6):
            p = np.array([0.2, 0.14, 0.0]) + rng.normal(size=3) * [0.6, 0.6, 0.0] + \
                [0, 0, rng.uniform(0.2, 1.5)]
            n = -np.array([rng.normal() * 0.3, rng.normal() * 0.3, 1.0])
            n /= np.linalg.norm(n)
            bound = emitter_groups.error_bound(g, 0, p, n)
            if bound is None:
                continue
            rect = _irradiance([g.corners[0]], [g.radiance[0]], p, n, 96)
            exact = _irradiance(quads, colours, p, n)
            assert np.all(np.abs(rect - exact) <= bound), (trial, p, n, rect, exact, bound)
            checked += 1
    assert checked >= 20


@pytest.mark.parametrize("form", sorted(FORMS))
def test_an_emitters_penumbra_is_filtered_as_a_rect_lights(form):
    """A box between the panel and the plane: the emissive quad's soft shadow goes
    through the rect light's filter (engine/gpu/passes/area_visibility.py), not each
    pixel's own taps on the light, which left a dither. The two maps differ a little at
    the box's silhouette, so the claim is on the mean over the penumbra: 2.2% of the
    unshadowed light, against 5.6% with each pixel's own taps (2026-11-28)."""
    from pxr import UsdLux
    from scipy.ndimage import binary_dilation

    import shadow_scenes

    def scene(light):
        stage = stage_with(light)
        shadow_scenes.add_box(stage, center=(1.5, 0.2, 0.35), size=0.7)
        return stage
    rect, quad = render(scene("rect"), form), render(scene("quad"), form)
    stage = scene("rect")
    UsdLux.ShadowAPI.Apply(stage.GetPrimAtPath("/root/rect")).CreateShadowEnableAttr(False)
    unshadowed = render(stage, form)
    panel = binary_dilation(quad > 1.02 * unshadowed, iterations=2)   # the quad seen
    penumbra = ~panel & (rect > 0.1 * unshadowed) & (rect < 0.9 * unshadowed)
    assert penumbra.sum() > 150
    err = float(np.mean(np.abs(quad[penumbra] - rect[penumbra]) / unshadowed[penumbra]))
    print(f"{form}: {int(penumbra.sum())} penumbra pixels, mean difference {err:.3f} "
          "of the unshadowed light")
    assert err < 0.035
