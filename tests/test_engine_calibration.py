"""Radiometric calibration: a white Lambert plane (diffuse 1, ior 1 so no specular,
roughness 1, metallic 0) seen straight down, one light at a time. The engine's pixel
radiance must equal E/pi with E from Blender's light forms, computed here in numpy
(area lights by direct numerical integration over the emitter, independent of the
engine's polygon formula)."""
import math

import numpy as np

import shadow_scenes
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux

from lantern.engine import RenderSettings, render_stage

W, H = 64, 48
CAM_Z = 4.0
FOCAL, HAP = 20.0, 36.0
VAP = HAP * H / W
TOL = 0.02


def plane_stage(half=20.0, cam_z=CAM_Z, far=100.0):
    stage = shadow_scenes.new_stage(half)  # the white Lambert plane at z = 0
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateFocalLengthAttr(FOCAL)
    cam.CreateHorizontalApertureAttr(HAP)
    cam.CreateVerticalApertureAttr(VAP)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, far))
    cam.AddTranslateOp().Set((0, 0, cam_z))  # looks down -Z
    return stage


def pixel_points(cam_z=CAM_Z):
    """World (x, y) on the plane at each pixel centre, row 0 = top."""
    j = (np.arange(W) + 0.5) / W * 2 - 1
    i = 1 - (np.arange(H) + 0.5) / H * 2
    x = j * (HAP / 2) / FOCAL * cam_z
    y = i * (VAP / 2) / FOCAL * cam_z
    X, Y = np.meshgrid(x, y)
    return np.stack([X, Y, np.zeros_like(X)], axis=-1)


# Both forms of the light pass (engine/gpu/passes/lights.py, clustered.py); the
# clustered one at error 0, where every light is shaded on its own within its volume.
FORMS = {"volumes": dict(lighting="volumes", compute=False),
         "clustered": dict(lighting="clustered", light_error=0.0)}


@pytest.fixture(params=sorted(FORMS))
def form(request):
    return request.param


def render(stage, form="clustered"):
    # Closed forms per pixel centre: one sample a pixel (no supersampling of small stills).
    res = render_stage(stage, RenderSettings(width=W, height=H, supersample=1, **FORMS[form]))
    assert np.isfinite(res.rgba).all()
    return res


def compare(img, expected, mask):
    got = img[..., 0][mask]
    exp = expected[mask]
    assert mask.sum() > 10
    err = np.abs(got - exp) / exp
    return float(err.max())


def sphere(stage, pos, intensity, radius, soft=True, point=False, path="/root/light"):
    light = UsdLux.SphereLight.Define(stage, path)
    light.CreateIntensityAttr(intensity)
    light.CreateNormalizeAttr(True)
    light.CreateRadiusAttr(radius)
    light.CreateTreatAsPointAttr(point)
    light.GetPrim().CreateAttribute("lantern:softFalloff", Sdf.ValueTypeNames.Bool).Set(soft)
    light.AddTranslateOp().Set(pos)
    return light


def point_expected(P, pos, I, r, soft):
    d = np.asarray(pos) - P
    d2 = np.sum(d * d, axis=-1)
    cos = d[..., 2] / np.sqrt(d2)
    E = I * np.clip(cos, 0, None) / (d2 + (r * r if soft else 0.0))
    return E / math.pi


@pytest.mark.parametrize("soft", [True, False])
def test_point_light(soft, form):
    stage = plane_stage()
    pos, intensity, r = (0.5, -0.3, 1.0), 1.0, 0.25
    sphere(stage, pos, intensity, r, soft=soft)
    res = render(stage, form)
    exp = point_expected(pixel_points(), pos, intensity / 4, r, soft)
    err = compare(res.rgba, exp, exp > 0.02 * exp.max())
    print(f"point soft={soft}: worst relative error {err:.2e}")
    assert err < TOL
    if form == "volumes":
        assert res.stats["light_volumes"] == 1  # camera inside its volume: still a volume


def test_point_light_outside_volume_is_cut_at_range(form):
    """Cut where it reflects 1e-4 W/(sr m2). The scene's level is set by a bright
    light under the plane (lighting none of it): in a scene of dim lights only, the
    threshold is relative (engine/lighting.py)."""
    stage = plane_stage()
    pos, intensity = (1.5, 0.0, 0.3), 1e-3
    sphere(stage, pos, intensity, 0.0, point=True)
    sphere(stage, (0.0, 0.0, -30.0), 100.0, 0.0, point=True, path="/root/under")
    res = render(stage, form)
    P = pixel_points()
    exp = point_expected(P, pos, intensity / 4, 0.0, True)
    from lantern.engine.lighting import VOLUME_THRESHOLD
    R = math.sqrt(intensity / 4 / (math.pi * VOLUME_THRESHOLD))
    dist = np.linalg.norm(P - np.asarray(pos), axis=-1)
    assert compare(res.rgba, exp, dist < 0.9 * R) < TOL
    assert np.all(res.rgba[..., 0][dist > 1.1 * R] == 0)
    if form == "volumes":
        assert res.stats["light_volumes"] == 2


def test_a_tree_light_is_not_cut_at_its_volume():
    """With an error bound (the default), a point light without shadows lights
    everything its light reaches: far from it, it joins a group of the light tree
    (engine/light_tree.py), never cut."""
    stage = plane_stage()
    pos, intensity = (1.5, 0.0, 0.3), 1e-3
    sphere(stage, pos, intensity, 0.0, point=True)
    sphere(stage, (0.0, 0.0, -30.0), 100.0, 0.0, point=True, path="/root/under")
    for name in ("/root/light", "/root/under"):
        UsdLux.ShadowAPI.Apply(stage.GetPrimAtPath(name)).CreateShadowEnableAttr(False)
    res = render_stage(stage, RenderSettings(width=W, height=H, supersample=1))
    exp = point_expected(pixel_points(), pos, intensity / 4, 0.0, True)
    assert compare(res.rgba, exp, exp > 0) < TOL

def test_camera_inside_point_volume(form):
    stage = plane_stage(cam_z=2.0)
    pos = (0.2, 0.1, 1.0)
    sphere(stage, pos, 0.01, 0.1)
    res = render(stage, form)
    P = pixel_points(cam_z=2.0)
    from lantern.engine.lighting import VOLUME_THRESHOLD
    R = math.sqrt(0.01 / 4 / (math.pi * VOLUME_THRESHOLD))
    assert np.linalg.norm(np.array([0, 0, 2.0]) - pos) < R  # the camera is inside
    exp = point_expected(P, pos, 0.01 / 4, 0.1, True)
    dist = np.linalg.norm(P - np.asarray(pos), axis=-1)
    assert compare(res.rgba, exp, dist < 0.9 * R) < TOL
    if form == "volumes":
        assert res.stats["light_volumes"] == 1


def test_spot_light(form):
    """Blender's cone form is exact for a point-sized spot; a spot with a radius has
    its edge softened as Cycles does (tests/test_shadows_vs_cycles.py measures that)."""
    stage = plane_stage()
    pos, half, blend = (0.0, 0.0, 2.0), 30.0, 0.3
    light = sphere(stage, pos, 5.0, 0.0)
    shaping = UsdLux.ShapingAPI.Apply(light.GetPrim())
    shaping.CreateShapingConeAngleAttr(half)
    shaping.CreateShapingConeSoftnessAttr(blend)
    res = render(stage, form)
    P = pixel_points()
    base = point_expected(P, pos, 5.0 / 4, 0.0, True)
    d = P - np.asarray(pos)
    cosphi = -d[..., 2] / np.linalg.norm(d, axis=-1)
    ch = math.cos(math.radians(half))
    t = np.clip((cosphi - ch) / ((1 - ch) * blend), 0, 1)
    exp = base * t * t * (3 - 2 * t)
    rad = np.linalg.norm(P[..., :2], axis=-1)
    inner = 2 * math.tan(math.acos(ch + (1 - ch) * blend))   # blend starts here
    outer = 2 * math.tan(math.radians(half))
    inside = rad < inner * 0.9
    in_blend = (rad > inner * 1.03) & (rad < outer * 0.97)
    outside = rad > outer * 1.05
    assert inside.any() and in_blend.any() and outside.any()
    e_in = compare(res.rgba, exp, inside)
    e_blend = compare(res.rgba, exp, in_blend & (exp > 0.05 * exp.max()))
    print(f"spot: inside {e_in:.2e}, blend {e_blend:.2e}")
    assert e_in < TOL and e_blend < 0.05  # blend: steep gradient over a pixel
    assert np.all(res.rgba[..., 0][outside] == 0)
    if form == "volumes":
        assert res.stats["light_volumes"] == 1  # drawn as a cone volume


def test_distant_light_at_angle(form):
    stage = plane_stage()
    light = UsdLux.DistantLight.Define(stage, "/root/sun")
    light.CreateIntensityAttr(3.0)
    light.CreateNormalizeAttr(True)
    light.AddRotateXOp().Set(40.0)
    res = render(stage, form)
    exp = np.full((H, W), 3.0 * math.cos(math.radians(40)) / math.pi)
    err = compare(res.rgba, exp, np.ones((H, W), bool))
    print(f"sun: worst relative error {err:.2e}")
    assert err < TOL


def area_expected(P, samples, normal, L, dA):
    """E/pi by direct integration: E = sum L cos_r cos_l / d^2 dA."""
    out = np.zeros(P.shape[:-1])
    flat = P.reshape(-1, 3)
    res = np.empty(len(flat))
    for k, p in enumerate(flat):
        d = samples - p
        d2 = np.sum(d * d, axis=1)
        cos_r = np.clip(d[:, 2] / np.sqrt(d2), 0, None)
        cos_l = np.clip(-(d @ normal) / np.sqrt(d2), 0, None)
        res[k] = np.sum(L * cos_r * cos_l / d2 * dA)
    out[:] = res.reshape(out.shape)
    return out / math.pi


def test_rect_light(form):
    stage = plane_stage()
    pos, w, h, intensity = np.array([0.3, 0.2, 1.5]), 1.2, 0.8, 50.0
    light = UsdLux.RectLight.Define(stage, "/root/rect")
    light.CreateIntensityAttr(intensity)
    light.CreateNormalizeAttr(True)
    light.CreateWidthAttr(w)
    light.CreateHeightAttr(h)
    light.AddTranslateOp().Set(Gf.Vec3d(*pos))
    res = render(stage, form)
    n = 120
    u = (np.arange(n) + 0.5) / n - 0.5
    U, V = np.meshgrid(u * w, u * h)
    samples = np.stack([pos[0] + U.ravel(), pos[1] + V.ravel(), np.full(U.size, pos[2])], 1)
    P = pixel_points()[::3, ::3]
    exp = area_expected(P, samples, np.array([0, 0, -1.0]), intensity / (w * h), w * h / n / n)
    err = compare(res.rgba[::3, ::3], exp, exp > 0.02 * exp.max())
    print(f"rect: worst relative error {err:.2e}")
    assert err < TOL


def test_disk_light(form):
    stage = plane_stage()
    pos, r, intensity = np.array([-0.2, 0.1, 1.0]), 0.5, 30.0
    light = UsdLux.DiskLight.Define(stage, "/root/disk")
    light.CreateIntensityAttr(intensity)
    light.CreateNormalizeAttr(True)
    light.CreateRadiusAttr(r)
    light.AddTranslateOp().Set(Gf.Vec3d(*pos))
    res = render(stage, form)
    nr, nphi = 60, 180
    rr = (np.arange(nr) + 0.5) / nr * r
    phi = (np.arange(nphi) + 0.5) / nphi * 2 * math.pi
    RR, PHI = np.meshgrid(rr, phi)
    samples = np.stack([pos[0] + (RR * np.cos(PHI)).ravel(), pos[1] + (RR * np.sin(PHI)).ravel(),
                        np.full(RR.size, pos[2])], 1)
    dA = (RR * (r / nr) * (2 * math.pi / nphi)).ravel()
    P = pixel_points()[::3, ::3]
    exp = area_expected(P, samples, np.array([0, 0, -1.0]), intensity / (math.pi * r * r), dA)
    err = compare(res.rgba[::3, ::3], exp, exp > 0.02 * exp.max())
    print(f"disk: worst relative error {err:.2e}")
    assert err < TOL


def test_no_nan_or_inf():
    stage = plane_stage()
    sphere(stage, (0.0, 0.0, 0.0), 10.0, 0.0, point=True)      # on the surface
    big = UsdLux.SphereLight.Define(stage, "/root/big")
    big.CreateIntensityAttr(1e6)
    big.CreateNormalizeAttr(True)
    big.CreateRadiusAttr(0.0)
    big.AddTranslateOp().Set((1.0, 1.0, 1e-4))
    res = render(stage)
    assert np.isfinite(res.rgba).all()
    assert res.rgba[..., :3].max() > 0
