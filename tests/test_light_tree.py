"""Clustered lighting and the light tree (engine/light_tree.py, engine/gpu/passes/
light_cull.py, clustered.py): the group's error model against brute force, culling
that never drops a light, and many small lights against the exact sum of all of them,
which numpy computes."""
import math
import sys

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux

from lantern.engine import RenderSettings, render_stage
from lantern.engine.light_tree import ERROR_CONSTANT, MIN_GROUP_RADII, build, group_irradiance
from lantern.engine.scene import Light
from light_grids import add_sphere_lights


def test_a_corrected_group_is_within_its_bound_of_its_lights():
    """Random groups (boxes, plates, lines of 2 to 64 lights) seen from random surfaces
    with every light above the horizon, from MIN_GROUP_RADII radii or further: the
    group's irradiance (centroid plus the second-order term) is within
    ERROR_CONSTANT (r/d)^3 / cos of the lights' sum,
    the test the shader makes (shaders/light_tree.glsl group_holds); without the term
    it is not."""
    rng = np.random.default_rng(7)
    worst, worst_plain, tried = 0.0, 0.0, 0
    while tried < 1500:
        k = int(rng.integers(2, 64))
        x = rng.uniform(-1, 1, (k, 3))
        shape = rng.integers(3)
        x[:, 2:] *= shape != 1
        x[:, 1:] *= shape != 2
        w = rng.uniform(0.1, 1.0, k)
        mu = np.average(x, axis=0, weights=w)
        r = np.linalg.norm(x - mu, axis=1).max()
        M = np.einsum("k,ki,kj->ij", w, x - mu, x - mu) / w.sum()
        d = r / rng.uniform(0.02, 1.0 / MIN_GROUP_RADII)
        direction = rng.normal(size=3)
        p = mu - direction / np.linalg.norm(direction) * d
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        u = x - p
        if (u @ n).min() <= 0:
            continue
        tried += 1
        exact = float(np.sum(w * (u @ n) / np.linalg.norm(u, axis=1) ** 3))
        cos = float(n @ (mu - p)) / d
        allowed = ERROR_CONSTANT * (r / d) ** 3 / cos
        grouped = group_irradiance([w.sum()], mu, M, p, n)[0]
        plain = w.sum() * float(n @ (mu - p)) / d ** 3
        worst = max(worst, abs(grouped / exact - 1) / allowed)
        worst_plain = max(worst_plain, abs(plain / exact - 1) / allowed)
    assert worst <= 1.0, worst
    assert worst_plain > 2.0, worst_plain


def test_the_tree_keeps_every_light_and_its_power():
    rng = np.random.default_rng(3)
    n = 1000
    lights = [Light(kind="point", name=str(i), color=rng.uniform(0, 1, 3),
                    position=rng.normal(size=3) * 10, shadow=False) for i in range(n)]
    tree = build(lights, np.arange(n) + 5, np.ones(n), 0.01)
    assert tree.leaves == 1024 and tree.count[0] == n
    pos = np.array([light.position for light in lights])
    w = np.array([light.color.sum() * 2 for light in lights])      # diffuse and specular
    mu = np.average(pos, axis=0, weights=w)
    assert np.allclose(tree.covariance[0], np.einsum("k,ki,kj->ij", w, pos - mu, pos - mu)
                       / w.sum())
    assert np.allclose(tree.diffuse[0], sum(light.color for light in lights))
    rows = tree.nodes[tree.leaves - 1:, 5, 3]
    assert sorted(rows[rows >= 0].astype(int)) == list(range(5, n + 5))
    assert np.allclose(tree.centroid[0], np.average(pos, axis=0, weights=[
        light.color.sum() for light in lights]))
    # The radius bounds every light of the node, from its centroid.
    assert np.linalg.norm(pos - tree.centroid[0], axis=1).max() <= tree.radius[0] + 1e-9


# --- Many small lights over a plane, against numpy -----------------------------------
SIDE, SPAN, HEIGHT, POWER = 128, 2.0, 1.0, 0.002      # 16,384 lights in a 2 m patch
EXTENT, PIXELS = 40.0, 48                             # a 40 m square seen from above


def plane_stage(positions, power, extent=EXTENT):
    """A white plane at z = 0 under an orthographic camera looking straight down
    (pixel centres at known points), and point lights of `power` watts, diffuse only."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    plane = UsdGeom.Mesh.Define(stage, "/root/plane")
    plane.CreateSubdivisionSchemeAttr("none")
    h = extent
    plane.CreatePointsAttr([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)])
    plane.CreateFaceVertexCountsAttr([4])
    plane.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    camera = UsdGeom.Camera.Define(stage, "/root/camera")
    camera.CreateProjectionAttr("orthographic")
    camera.CreateHorizontalApertureAttr(extent * 10)      # tenths of a scene unit
    camera.CreateVerticalApertureAttr(extent * 10)
    camera.CreateClippingRangeAttr(Gf.Vec2f(1, 40))       # depth precision on the plane
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, 20))
    add_sphere_lights(stage, "/root", positions,
                      {"intensity": power / (4 * math.pi), "specular": 0.0}, False,
                      treat_as_point=True)
    return stage


def pixel_points(extent=EXTENT, pixels=PIXELS):
    c = ((np.arange(pixels) + 0.5) / pixels - 0.5) * extent
    return np.meshgrid(c, -c)


def irradiance(points, positions):
    """Sum of cos / d^2 over point lights at `positions` on the plane z = 0."""
    X, Y = points
    total = np.zeros_like(X)
    for x, y, z in positions:
        total += z / ((X - x) ** 2 + (Y - y) ** 2 + z * z) ** 1.5
    return total


def render(stage, light_error=0.01, pixels=PIXELS):
    settings = RenderSettings(width=pixels, height=pixels, preset="low", ambient_occlusion=False,
                              fxaa=False, supersample=1, light_error=light_error,
                              lighting="clustered")
    return render_stage(stage, settings)


def patch():
    g = (np.arange(SIDE) + 0.5) / SIDE * SPAN - SPAN / 2
    return [(float(x), float(y), HEIGHT) for y in g for x in g]


def test_many_small_lights_are_their_exact_sum_within_the_bound():
    """16,384 small lights in a patch over a plane against one light of their total
    power at its centre: at every plane pixel the ratio of the two images is the ratio
    of their inverse-square sums within the bound (1% and 0.2%), under the patch and
    20 m from it, where each small light alone lies far below any cut-off (and the
    groups carry it)."""
    from lantern.engine import Session
    many = patch()
    points = pixel_points()
    expected = irradiance(points, many) / (len(many) * irradiance(points, [(0, 0, HEIGHT)]))
    X, Y = points
    assert (np.hypot(X, Y) > 15).any() and (np.hypot(X, Y) < 1).any()
    settings = RenderSettings(width=PIXELS, height=PIXELS, preset="low", lighting="clustered",
                              ambient_occlusion=False, fxaa=False, supersample=1)
    with Session(plane_stage(many, POWER), settings) as lots, \
            Session(plane_stage([(0.0, 0.0, HEIGHT)], POWER * len(many)), settings) as one:
        for light_error in (0.01, 0.002):
            lots.configure(light_error=light_error)
            one.configure(light_error=light_error)
            image, single = lots.render(), one.render()
            ratio = image.rgba[..., 0].astype(np.float64) / single.rgba[..., 0]
            error = np.abs(ratio / expected - 1)
            assert error.max() <= light_error, (light_error, error.max())
            # The groups did the work: far fewer items than lights in every cluster.
            assert image.stats["clusters_overflowed"] == 0
            assert image.stats["light_items"] < 0.2 * len(many) * image.stats["light_clusters"]


def test_65536_lights_are_the_sum_of_renders_of_their_parts():
    """65,536 lights on a 256 x 256 grid over 60 m, at 1 m: the whole against the sum
    of renders of its two halves (alternate lights, each under a prim that one session
    deactivates in turn), within twice the bound (each render is within it of the
    exact sum), and within the bound of numpy's sum."""
    from lantern.engine import Session
    g = np.linspace(-30.0, 30.0, 256)
    lights = [(float(x), float(y), 1.0) for y in g for x in g]
    pixels, extent = 32, 64.0
    stage = plane_stage([], 0.0, extent)
    for i, half in enumerate((lights[0::2], lights[1::2])):
        UsdGeom.Xform.Define(stage, f"/root/half{i}")
        add_sphere_lights(stage, f"/root/half{i}", half, {"intensity": 0.05 / (4 * math.pi),
                                                          "specular": 0.0}, False,
                          treat_as_point=True)
    halves = [stage.GetPrimAtPath(f"/root/half{i}") for i in range(2)]
    settings = RenderSettings(width=pixels, height=pixels, preset="low", lighting="clustered",
                              ambient_occlusion=False, fxaa=False, supersample=1)
    with Session(stage, settings) as session:
        whole = session.render()
        halves[1].SetActive(False)
        first = session.render().rgba[..., 0].astype(np.float64)
        halves[1].SetActive(True)
        halves[0].SetActive(False)
        second = session.render().rgba[..., 0].astype(np.float64)
    assert whole.stats["clusters_overflowed"] == 0
    got = whole.rgba[..., 0].astype(np.float64)
    assert np.all(np.abs(got / (first + second) - 1) <= 0.02)
    points = pixel_points(extent, pixels)
    one = render(plane_stage([(0.0, 0.0, 1.0)], 0.05, extent), pixels=pixels).rgba[..., 0]
    scale = np.median(one / irradiance(points, [(0.0, 0.0, 1.0)]))
    assert np.all(np.abs(got / (irradiance(points, lights) * scale) - 1) <= 0.01)


# --- Culling never drops a light --------------------------------------------------------
def test_lights_that_reach_few_pixels_are_never_dropped():
    """300 lights of short reach (error 0: each cut where its volume ends) scattered
    over a plane and a box seen at an angle, so that many just touch a cluster's tile
    corners or slice ends: the clustered pass lights exactly the pixels the light
    volumes light, with the same values."""
    W, H = 96, 64
    stage = plane_stage([], 0.0, extent=8.0)
    camera = UsdGeom.Camera.Get(stage, "/root/camera")
    camera.GetProjectionAttr().Set("perspective")
    camera.GetHorizontalApertureAttr().Set(36.0)
    camera.GetVerticalApertureAttr().Set(36.0 * H / W)
    camera.CreateFocalLengthAttr(24.0)
    camera.GetPrim().RemoveProperty("xformOpOrder")
    look = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, -6, 4), Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 0, 1))
    camera.AddTransformOp().Set(look.GetInverse())
    box = UsdGeom.Cube.Define(stage, "/root/box")
    box.AddTranslateOp().Set(Gf.Vec3d(0.5, 0.5, 0.5))
    rng = np.random.default_rng(11)
    for i in range(300):
        light = UsdLux.SphereLight.Define(stage, f"/root/small_{i:03d}")
        light.CreateIntensityAttr(float(rng.uniform(1e-5, 1e-4)))
        light.CreateTreatAsPointAttr(True)
        UsdLux.ShadowAPI.Apply(light.GetPrim()).CreateShadowEnableAttr(False)
        x, y = rng.uniform(-4, 4), rng.uniform(-3, 5)
        light.AddTranslateOp().Set(Gf.Vec3d(x, y, float(rng.uniform(0.01, 1.2))))
    # A bright light under the plane sets the volumes' threshold (engine/lighting.py):
    # the small lights then reach a few decimetres.
    bright = UsdLux.SphereLight.Define(stage, "/root/bright")
    bright.CreateIntensityAttr(2000.0)
    bright.CreateTreatAsPointAttr(True)
    bright.AddTranslateOp().Set(Gf.Vec3d(0, 0, -50))
    settings = dict(width=W, height=H, preset="low", ambient_occlusion=False, fxaa=False,
                    supersample=1)
    volumes = render_stage(stage, RenderSettings(**settings, lighting="volumes", compute=False))
    clustered = render_stage(stage, RenderSettings(**settings, lighting="clustered", light_error=0.0))
    a, b = volumes.rgba[..., :3], clustered.rgba[..., :3]
    lit = a[..., 0] > 0
    assert 0.05 < lit.mean() < 0.9               # lights that reach some pixels, not all
    assert np.array_equal(lit, b[..., 0] > 0)
    assert np.allclose(a, b, rtol=1e-5, atol=0)


def test_a_frame_in_which_no_light_changed_asks_nothing_of_each_light(monkeypatch):
    """Which lights cast and which go through the tree is sorted when a light changes,
    not by a loop over every light in passes of every frame (on an H100, a frame of
    16,384 lights took 21.6 ms of CPU, one light 2.5 ms)."""
    from lantern.engine import Session, light_tree, shadow_plan
    stage = plane_stage(patch()[:64], 1.0)
    # And one light with a shadow, over a caster: the shadow pass runs every frame.
    add_sphere_lights(stage, "/root", [(0.0, 0.0, 2.0)], {"intensity": 1.0}, True)  # light_0
    caster = UsdGeom.Mesh.Define(stage, "/root/caster")
    caster.CreateSubdivisionSchemeAttr("none")
    caster.CreatePointsAttr([(-0.2, -0.2, 1.0), (0.2, -0.2, 1.0), (0.2, 0.2, 1.0), (-0.2, 0.2, 1.0)])
    caster.CreateFaceVertexCountsAttr([4])
    caster.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    asked = []
    for real in (light_tree.in_tree, shadow_plan.casts):    # wherever a module holds them
        for module in [m for n, m in sys.modules.items() if n.startswith("lantern.")]:
            if getattr(module, real.__name__, None) is real:
                monkeypatch.setattr(module, real.__name__,
                                    lambda *a, real=real: asked.append(real) or real(*a))
    settings = RenderSettings(width=PIXELS, height=PIXELS, preset="low", lighting="clustered")
    with Session(stage, settings) as session:
        result = session.render()
        first = result.rgba
        assert result.stats["shadow_maps"] >= 1
        assert asked, "the first frame sorts the lights"
        asked.clear()
        again = session.render().rgba
    assert asked == [] and np.array_equal(first, again)


# --- Many lights close together -------------------------------------------------------
DENSE_SIDE, DENSE_PITCH, DENSE_HEIGHT = 128, 0.03, 0.3     # 16,384 lights, 3.84 m across
DENSE_EXTENT = 8.0                                           # metres across the view


def dense_patch():
    g = (np.arange(DENSE_SIDE) - (DENSE_SIDE - 1) / 2) * DENSE_PITCH
    return [(float(x), float(y), DENSE_HEIGHT) for y in g for x in g]


def dense_stage(positions, power, width, height):
    """plane_stage's plane and lights under a view DENSE_EXTENT wide of width:height."""
    stage = plane_stage(positions, power, DENSE_EXTENT)
    camera = UsdGeom.Camera.Get(stage, "/root/camera")
    camera.GetVerticalApertureAttr().Set(DENSE_EXTENT * 10 * height / width)
    return stage


def wide_pixel_points(extent, width, height):
    """The plane points at the pixel centres of dense_stage's view (rows top down)."""
    x = ((np.arange(width) + 0.5) / width - 0.5) * extent
    y = -((np.arange(height) + 0.5) / height - 0.5) * extent * height / width
    return np.meshgrid(x, y)


def test_lights_close_together_take_a_short_cut_within_the_bound():
    """16,384 lights 3 cm apart, 0.3 m over a plane: near the patch every light is
    within reach of every pixel, so a group's error bounded against its own light
    (the pixel's first test) opens almost every node. Against the pixel's light (the
    second), each pixel takes a few dozen groups: the light tree's steps (nodes
    visited) stay few, the clusters list few nodes, and the light stays within the
    bound (1%) of numpy's exact sum at every plane pixel (the single light of their
    total power at the patch's centre gives the plane's radiance per irradiance)."""
    from lantern.engine import Session
    w, h = 160, 90
    many = dense_patch()
    points = wide_pixel_points(DENSE_EXTENT, w, h)
    expected = irradiance(points, many) / (len(many) * irradiance(points, [(0, 0, DENSE_HEIGHT)]))
    settings = RenderSettings(width=w, height=h, preset="low", lighting="clustered",
                              ambient_occlusion=False, fxaa=False, supersample=1)
    with Session(dense_stage(many, 0.002, w, h), settings) as lots, \
            Session(dense_stage([(0.0, 0.0, DENSE_HEIGHT)], 0.002 * len(many), w, h),
                    settings) as one:
        image, single = lots.render(), one.render()
    ratio = image.rgba[..., 0].astype(np.float64) / single.rgba[..., 0]
    error = np.abs(ratio / expected - 1)
    assert error.max() <= 0.01, error.max()
    stats = image.stats
    assert stats["clusters_overflowed"] == 0
    # One slice a tile (the plane seen from above): nodes listed per cluster.
    tiles = -(-w // 16) * -(-h // 16)
    assert stats["light_items"] / tiles <= 80, stats
    # Every pixel walks: a plane pixel's cut, under the patch and beside it.
    assert stats["light_tree_pixels"] == w * h
    assert stats["light_tree_steps"] / stats["light_tree_pixels"] <= 160, stats
    assert stats["light_tree_steps_max"] <= 320, stats
