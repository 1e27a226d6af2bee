"""The shading work's image acceptances (docs/rendering.md; the engine half but
transparency), against the Cycles references in references/looks/ (direct light, Cycles'
1.5 px Blackman-Harris filter). Every scene comes from reference_scenes.build, exported
in memory as `lantern render scene.blend` does, and renders at its reference size.

Figures are printed (pytest -s shows them); docs/rendering.md's tables come from
bench/bench_presets.py."""
import functools
import pathlib
import re

import numpy as np
import pytest

import reference_scenes
from image_metrics import mean_flip

LOOKS = pathlib.Path(__file__).resolve().parent / "references" / "looks"
FRAMES = {"demo": 13.0}      # the frame the reference shows
CORPUS = ["02_suzanne", "01_principled_material", "09_tex_wrapping_mirror", "01_alpha_blend",
          "01_alpha_mask", "demo"]


@functools.lru_cache(maxsize=None)
def stage_of(name):
    """The reference scene's stage, exported once per test session."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    workdir = pathlib.Path(__import__("tempfile").gettempdir()) / "lantern-looks-tests"
    reference_scenes.build(name, workdir)
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    return stage


def render(name, **settings):
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    w, h = reference_scenes.SCENES[name].size
    settings.setdefault("frame", FRAMES.get(name))
    settings.setdefault("width", w)
    settings.setdefault("height", h)
    return render_stage(stage_of(name), RenderSettings(bounces=DIRECT, **settings))


def reference(name):
    from lantern.engine import read_exr
    return read_exr(str(LOOKS / f"{name}.exr")).astype(np.float64)


@functools.lru_cache(maxsize=None)
def medium_flip(name, supersample=None) -> float:
    """HDR-FLIP of the scene at the default preset (medium) against Cycles, rendered once
    for the tests that hold other presets or FXAA to it (a render is deterministic).
    supersample=1: one sample a pixel and FXAA, as medium draws images over 320x240 (it
    supersamples smaller stills, as these)."""
    return mean_flip(render(name, preset="medium", supersample=supersample).rgba, reference(name))


def table(name):
    """{scene: FLIP} of a committed table (BEFORE.md, EXPORTER.md)."""
    rows = re.findall(r"^\| (\S+) \| ([0-9.]+) \|", (LOOKS / name).read_text(), re.M)
    return {scene: float(flip) for scene, flip in rows}


def interior(mask):
    """Covered pixels whose 8 neighbours are covered too (edges are anti-aliasing's)."""
    out = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            out &= np.roll(np.roll(mask, dy, 0), dx, 1)
    return out


def surface(result):
    return result.passes["Depth"][..., 0] < 1e9


# --- environment ---------------------------------------------------------------------------

def quadrant_errors(name):
    result = render(name, passes=frozenset(["Depth"]))
    image, ref = result.rgba[..., :3].astype(np.float64), reference(name)
    sphere = interior(surface(result))
    h, w = sphere.shape
    errors = []
    for qy in (0, 1):
        for qx in (0, 1):
            q = (slice(qy * h // 2, (qy + 1) * h // 2), slice(qx * w // 2, (qx + 1) * w // 2))
            m = sphere[q]
            assert m.sum() > 100
            errors.append(float(np.mean(np.abs(image[q][m] - ref[q][m]) / np.maximum(ref[q][m], 1e-3))))
    return errors


@pytest.mark.parametrize("name", ["environment_diffuse", "environment_mirror"])
def test_environment_sphere_quadrants_within_3_percent(name):
    """Mean relative error over the sphere's pixels of each image quadrant."""
    errors = quadrant_errors(name)
    print(f"{name}: mean relative error per quadrant {['%.4f' % e for e in errors]}")
    assert max(errors) <= 0.03


def sphere_halves(mask, count):
    """[(upper, lower)] masks of `count` spheres in a row, left to right: each one's
    pixels within 0.85 of its radius on screen (the rim's mix with the sky left out),
    split at its centre row."""
    h, w = mask.shape
    yy, xx = np.mgrid[0:h, 0:w]
    halves = []
    for i in range(count):
        own = mask & (xx >= w * i // count) & (xx < w * (i + 1) // count)
        ys, xs = np.nonzero(own)
        cy, cx, radius = ys.mean(), xs.mean(), np.sqrt(own.sum() / np.pi)
        inner = own & ((yy - cy) ** 2 + (xx - cx) ** 2 < (0.85 * radius) ** 2)
        halves.append((inner & (yy < cy), inner & (yy >= cy)))
    return halves


def test_dome_probe_sphere_halves_within_3_percent():
    """Five spheres under the sky (reference_scenes.PROBE: white metal of roughness 1,
    0.6 and 0.3, a rough dielectric, a Lambert): each sphere half's mean per channel
    within 3% of Cycles at medium. Before the dome's reflections were integrated over
    the lobe (environment.glsl dome_specular) the metals were 2-21% off."""
    result = render("dome_probe", passes=frozenset(["Depth"]))
    image, ref = result.rgba[..., :3].astype(np.float64), reference("dome_probe")
    worst = 0.0
    for (name, _, _), pair in zip(reference_scenes.PROBE, sphere_halves(surface(result), 5)):
        for half, mask in zip(("upper", "lower"), pair):
            assert mask.sum() > 200
            error = image[mask].mean(axis=0) / ref[mask].mean(axis=0) - 1.0
            print(f"{name} {half}: {np.round(100 * error, 2)} %")
            worst = max(worst, np.abs(error).max())
    assert worst <= 0.03


def brightest(image, weights):
    """(row, col) of the pixel whose weighted colour is largest."""
    return np.array(np.unravel_index(np.argmax(image[..., :3] @ np.asarray(weights)), image.shape[:2]))


def glints(image):
    """Where the mirror sphere shows the sky's sun and its green patch."""
    return brightest(image, (1.0, 0.8, 0.2)), brightest(image, (-1.0, 1.0, -1.0))


def test_mirror_sphere_shows_the_map_where_cycles_does():
    ref_sun, ref_patch = glints(reference("environment_mirror"))
    sun, patch = glints(render("environment_mirror").rgba)
    print(f"sun glint {sun} (Cycles {ref_sun}), green patch {patch} (Cycles {ref_patch})")
    assert np.abs(sun - ref_sun).max() <= 1 and np.abs(patch - ref_patch).max() <= 1


def test_a_turned_dome_moves_the_glints():
    """Negative control: the same stage with the dome turned 90 degrees about the up
    axis puts the reflections elsewhere (the orientation check above can fail)."""
    from pxr import Gf, UsdGeom
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    stage = stage_of("environment_mirror")
    dome = UsdGeom.Xformable(stage.GetPrimAtPath("/root/_world"))
    op = dome.GetOrderedXformOps()[0]
    before = op.Get()
    try:
        op.Set(before * Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(0, 0, 1), 90)))
        turned = render_stage(stage, RenderSettings(bounces=DIRECT, width=128, height=72)).rgba
    finally:
        op.Set(before)
    ref_sun, ref_patch = glints(reference("environment_mirror"))
    sun, patch = glints(turned)
    assert max(np.abs(sun - ref_sun).max(), np.abs(patch - ref_patch).max()) > 3


# --- ambient occlusion ---------------------------------------------------------------------

def ambient_error(result, ref):
    """Relative L1 error of the world's light on the drawn pixels."""
    m = surface(result)
    image = result.rgba[..., :3].astype(np.float64)
    return float(np.abs(image - ref)[m].sum() / ref[m].sum())


def test_ao_corner_error_falls_with_the_preset_and_halves():
    ref = reference("ao_corner")
    off = ambient_error(render("ao_corner", ambient_occlusion=False, passes=frozenset(["Depth"])), ref)
    errors = {p: ambient_error(render("ao_corner", preset=p, passes=frozenset(["Depth"])), ref)
              for p in ("low", "medium", "high", "ultra")}
    print(f"ao_corner ambient error (relative L1): off {off:.4f}, " +
          ", ".join(f"{p} {e:.4f}" for p, e in errors.items()))
    values = list(errors.values())
    assert all(a > b for a, b in zip(values, values[1:])), errors
    assert errors["ultra"] <= 0.5 * off


def test_ao_searched_once_a_block_at_low_and_medium_is_near_every_pixels(monkeypatch):
    """Low and medium search AO once per 2 x 2 pixels and the blur fills in the rest
    (core/presets.py ao_block): the search is 4x cheaper, and the occlusion varies over
    the AO distance, far wider than a pixel. Against a search at every pixel, on the AO
    corner at 2x and 4x its reference size: the ambient light differs by little, less at
    the larger size, and the error against Cycles at the reference size hardly moves."""
    import dataclasses
    from lantern.core import presets
    ref = reference("ao_corner")
    w, h = reference_scenes.SCENES["ao_corner"].size
    blocked = render("ao_corner", passes=frozenset(["Depth"]))
    assert blocked.stats["ao_searches"] == (w // 2) * (h // 2)
    differences = {}
    for scale in (2, 4):
        size = dict(width=w * scale, height=h * scale)
        a = render("ao_corner", **size, passes=frozenset(["Depth"]))
        with monkeypatch.context() as m:
            m.setitem(presets.PRESETS, "medium", dataclasses.replace(presets.PRESETS["medium"], ao_block=1))
            b = render("ao_corner", **size, passes=frozenset(["Depth"]))
            if scale == 2:
                every = render("ao_corner", passes=frozenset(["Depth"]))
        assert b.stats["ao_searches"] == 4 * a.stats["ao_searches"]
        differences[scale] = ambient_error(a, b.rgba[..., :3].astype(np.float64))
    blocked_error, every_error = ambient_error(blocked, ref), ambient_error(every, ref)
    print(f"ao_corner, AO in 2x2 blocks against every pixel: ambient differs by "
          f"{differences[2]:.4f} at 2x, {differences[4]:.4f} at 4x; error against Cycles "
          f"{blocked_error:.4f} against {every_error:.4f}")
    assert differences[4] < differences[2] < 0.015          # measured 0.0069, 0.0104
    assert blocked_error < 1.05 * every_error               # measured 1.01x


def test_an_ambient_occlusion_node_darkens_the_base_colour_by_the_ao_pass():
    """ao_node: the surfaces' base colour through an Ambient Occlusion node. Drawn with
    the AO pass's occlusion on the albedo it is nearer Cycles than the node ignored (a
    plain 0.8 grey), and the error is the screen-space AO's own (ao_corner's)."""
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    stage, ref = stage_of("ao_node"), reference("ao_node")
    material = next(p for p in stage.Traverse() if p.GetTypeName() == "Material")
    flag = material.GetAttribute("lantern:baseColorOcclusion")
    assert flag.Get() is True
    w, h = reference_scenes.SCENES["ao_node"].size
    with_node = mean_flip(render("ao_node").rgba, ref)
    flag.Set(False)
    try:
        ignored = mean_flip(render_stage(stage, RenderSettings(bounces=DIRECT, width=w, height=h)).rgba, ref)
    finally:
        flag.Set(True)
    print(f"ao_node FLIP (medium): {with_node:.4f}, the node ignored {ignored:.4f}")
    assert with_node < 0.7 * ignored and with_node < 0.25


def test_ao_radius_follows_blenders_ao_distance():
    """The world's AO distance is exported (lantern:aoDistance) and read: a short
    distance finds less occlusion in the corner than Blender's default 10 m."""
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    stage = stage_of("ao_corner")
    attr = stage.GetPrimAtPath("/root/_world").GetAttribute("lantern:aoDistance")
    assert attr and attr.Get() == pytest.approx(10.0)
    long = render_stage(stage, RenderSettings(bounces=DIRECT, width=128, height=72, passes=frozenset(["AO"])))
    attr.Set(0.2)
    try:
        short = render_stage(stage, RenderSettings(bounces=DIRECT, width=128, height=72, passes=frozenset(["AO"])))
    finally:
        attr.Set(10.0)
    assert short.passes["AO"].mean() > long.passes["AO"].mean() + 0.05


# --- energy ------------------------------------------------------------------------------

@pytest.mark.parametrize("name, bound", [("furnace_rough0", 0.03), ("furnace_rough05", 0.03),
                                         ("furnace_rough1", 0.03), ("furnace_clearcoat", 0.05)])
def test_furnace_mean_against_cycles(name, bound):
    result = render(name, passes=frozenset(["Depth", "GlossDir"]))
    sphere = surface(result)
    mean = result.rgba[..., :3][sphere].mean()
    ref = reference(name)[sphere].mean()
    glossy = result.passes["GlossDir"][sphere].mean()
    print(f"{name}: mean {mean:.4f}, Cycles {ref:.4f}, glossy part {glossy:.4f}")
    assert abs(mean / ref - 1) <= bound
    # The specular layer reflects a share of the light and the layers below it give
    # that share up: without the (1 - E) weighting the sphere would be brighter by
    # about `glossy`, an error this check sees even where the 3 % bound would not.
    assert glossy > 0.01 and abs(mean - ref) < 0.5 * glossy


# --- textures -----------------------------------------------------------------------------

def far_band(name, **settings):
    result = render(name, passes=frozenset(["Depth"]), **settings)
    band = result.passes["Depth"][..., 0]
    far = (band > 10.0) & (band < 1e9)
    return result.rgba[..., 0][far].mean(), reference(name)[..., 0][far].mean()


def test_grazing_checker_far_band_filters_as_cycles():
    ours, cycles = far_band("tex_grazing_checker")
    eevee, _ = far_band("tex_grazing_checker", srgb_filtering="linear")
    print(f"far band: {ours:.4f} (EEVEE's way {eevee:.4f}), Cycles {cycles:.4f}")
    assert abs(ours / cycles - 1) <= 0.05
    assert abs(ours - cycles) < abs(eevee - cycles)


TEXTURED = ["tex_grazing_checker", "01_principled_material", "02_suzanne", "demo",
            "09_tex_wrapping_mirror"]


@pytest.mark.parametrize("preset", ["high", "ultra"])
@pytest.mark.parametrize("name", TEXTURED)
def test_supersampled_presets_are_no_worse_than_medium(name, preset):
    """A preset that costs more is not less accurate: high (2x2 supersampled) and
    ultra (3x3) have an HDR-FLIP against Cycles no higher than medium's with one sample
    and FXAA (as medium draws images over 320x240) on every textured reference scene. Each lookup filters what Cycles' point
    lookups would average to (material.glsl sample_map): at medium Cycles' pixel
    filter, in a supersampled image its sub-pixel. Geometric edges lie where the edge
    samples put them (passes/antialias.py): 09_tex_wrapping_mirror's squares, whose
    edges lie along the pixel rows and columns, were 0.0323 at high without them,
    against medium's 0.0192."""
    medium = medium_flip(name, supersample=1)
    flip = mean_flip(render(name, preset=preset).rgba, reference(name))
    print(f"{name}: {preset} {flip:.4f}, medium {medium:.4f}")
    assert flip <= medium


def test_a_grazing_turned_checker_has_no_band_and_each_preset_beats_the_one_below():
    """tex_grazing_rotated (a checker on a plane turned 30 degrees, 1.8 to 22 degrees
    under the view): high is as accurate as medium and ultra as high, and no row's
    mean brightness steps away from Cycles' (a band: where GL's filter read the
    image's level 0 and averaged it in linear light, supersampled lookups drew 0.50
    where Cycles has 0.45, a step of 0.03-0.05 in a row's mean)."""
    name = "tex_grazing_rotated"
    ref = reference(name)
    flips, steps = {}, {}
    for preset in ("medium", "high", "ultra"):
        image = render(name, preset=preset).rgba[..., :3]
        flips[preset] = mean_flip(image, ref)
        off = image.mean(axis=(1, 2)) - ref.mean(axis=(1, 2))       # per row, from Cycles
        steps[preset] = float(np.abs(np.diff(off)).max())
        print(f"{name} {preset}: HDR-FLIP {flips[preset]:.4f}, largest row step from "
              f"Cycles {steps[preset]:.4f}")
    assert flips["high"] <= flips["medium"] and flips["ultra"] <= flips["high"]
    assert max(steps.values()) < 0.01


def test_16_bit_ramp_keeps_more_than_256_levels(tmp_path):
    result = render("tex_gradient16", fxaa=False)
    row = result.rgba[4, :, 0]
    levels = len(np.unique(row))
    print(f"16-bit ramp: {levels} levels across {row.size} pixels")
    assert levels > 256


def test_exr_texture_of_four_renders_four():
    result = render("tex_exr4", fxaa=False)
    assert np.allclose(result.rgba[..., :3], 4.0, atol=2e-3)


# --- anti-aliasing and corpus --------------------------------------------------------------

@pytest.mark.parametrize("name", CORPUS)
def test_corpus_scene_against_cycles(name):
    """FLIP against the Cycles reference, lower than before the shading work (BEFORE.md)
    (with FXAA and one sample a pixel too, as medium draws images over 320x240), and
    FXAA (the medium preset's there) lowers it."""
    flip, one = medium_flip(name), medium_flip(name, supersample=1)
    without = mean_flip(render(name, fxaa=False, supersample=1).rgba, reference(name))
    before, exporter = table("BEFORE.md")[name], table("EXPORTER.md")[name]
    print(f"{name}: FLIP {flip:.4f} (one sample {one:.4f}, FXAA off {without:.4f}; before "
          f"the shading work {before:.4f}, exporter half {exporter:.4f})")
    assert flip < before and one < before
    assert one < without


def test_sheen_lobes_match_cycles():
    """sheen: Cycles' microfiber sheen (the Principled BSDF's, layered over the rest and
    over a coat; a Sheen BSDF added and alone) and its velvet, lit by a sun from behind
    and a grey world. Within HDR-FLIP 0.05 at ultra, each sphere's mean within 2% of
    Cycles' and its pixels within 1.5% (relative L1); with the sheen left out the image is far off. A frame without a sheen
    makes no sheen target."""
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    from lantern.engine.gpu.framegraph import Frame
    from lantern.engine.gpu.passes.gbuffer import GBufferPass
    from lantern.engine.usd.stage import StageReader
    stage, ref = stage_of("sheen"), reference("sheen")
    w, h = reference_scenes.SCENES["sheen"].size
    image = render("sheen", preset="ultra").rgba
    flip = mean_flip(image, ref)
    spheres = reference_scenes.SHEEN_SPHERES
    means = {}
    for i, (label, _, _) in enumerate(spheres):
        cols = slice(w * i // len(spheres), w * (i + 1) // len(spheres))
        means[label] = (image[:, cols, :3].mean(), ref[:, cols, :3].mean(),
                        np.abs(image[:, cols, :3] - ref[:, cols, :3]).sum() /
                        ref[:, cols, :3].sum())
    modes = {}
    for prim in stage.Traverse():
        if prim.GetTypeName() == "Material" and prim.GetAttribute("lantern:sheenMode"):
            modes[prim.GetPath()] = prim.GetAttribute("lantern:sheenMode").Get()
            prim.GetAttribute("lantern:sheenMode").Set("none")   # read as no sheen
    try:
        without = render_stage(stage, RenderSettings(bounces=DIRECT, width=w, height=h, preset="ultra"))
        reader = StageReader(stage)
        reader.sync(None)
        reader.close()
        wanted = GBufferPass.wanted(None, Frame(reader.scene, None, (1, 1), None))
    finally:
        for path, mode in modes.items():
            stage.GetPrimAtPath(path).GetAttribute("lantern:sheenMode").Set(mode)
    ignored = mean_flip(without.rgba, ref)
    print(f"sheen FLIP (ultra): {flip:.4f}, the sheen ignored {ignored:.4f}; means " +
          ", ".join(f"{k} {a:.4f}/{b:.4f} (L1 {e:.4f})" for k, (a, b, e) in means.items()))
    assert len(modes) == len(spheres)
    assert flip < 0.05 and flip < 0.3 * ignored
    for label, (lantern, cycles, error) in means.items():
        assert lantern == pytest.approx(cycles, rel=0.02) and error < 0.015, label
    assert "g_sheen" not in wanted
    assert sum("lantern:sheenMode 'none' is not one of" in line
               for line in without.warnings) == len(spheres), without.warnings


def test_a_blended_sheen_is_half_the_opaque_one_over_the_world():
    """A see-through material's sheen is drawn (by the transparency pass): a sheen
    sphere at alpha 0.5 over the uniform world is half its opaque self and half the
    world, as Cycles mixes the whole BSDF with a transparent one (shadows and the
    screen-space occlusion, which the two passes treat differently, off)."""
    import bpy
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.bounces import DIRECT
    from lantern.exporters import stage_from_depsgraph
    workdir = pathlib.Path(__import__("tempfile").gettempdir()) / "lantern-looks-tests"
    reference_scenes.build("sheen", workdir)
    bpy.data.objects["Sun"].data.use_shadow = False
    material = bpy.data.materials["Sheen_principled"]
    material.use_backface_culling = True     # the sphere's far side would show through
    bsdf = material.node_tree.nodes["Principled BSDF"]
    w, h = reference_scenes.SCENES["sheen"].size
    settings = RenderSettings(bounces=DIRECT, width=w, height=h, preset="medium", ambient_occlusion=False)
    images = {}
    for alpha in (1.0, 0.5):
        bsdf.inputs["Alpha"].default_value = alpha
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        images[alpha] = render_stage(stage, settings).rgba[..., :3].astype(np.float64)
    world = 0.3
    cols = slice(0, w // len(reference_scenes.SHEEN_SPHERES))
    opaque, blended = images[1.0][:, cols], images[0.5][:, cols]
    sphere = interior(np.abs(opaque - world).max(axis=-1) > 0.02)
    expected = 0.5 * opaque + 0.5 * world
    error = np.abs(blended - expected)[sphere].mean() / expected[sphere].mean()
    rim = sphere & (opaque.mean(axis=-1) > np.percentile(opaque.mean(axis=-1)[sphere], 90))
    print(f"blended sheen sphere: relative error {error:.4f} over {sphere.sum()} px")
    assert sphere.sum() > 200 and rim.any()
    assert error < 0.01
    assert np.abs(blended - expected)[rim].mean() < 0.01
