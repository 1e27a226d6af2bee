"""UsdLux lights -> light records in Lantern's radiometric convention (see the stage
contract: 1 nit = 1 W/(sr m2)).

With `inputs:normalize = true` (what the exporter writes), for s = intensity *
2^exposure * color:
  SphereLight (point, spot): radiant intensity I = s / 4 W/sr. (Emitted radiance
      s / (4 pi r^2) times the projected area pi r^2.)
  RectLight / DiskLight: radiance L = s / area.
  DistantLight: irradiance E = s.
Without normalize, `intensity` is USD radiance: sphere I = s * pi r^2 (s when
treatAsPoint or r = 0), rect/disk L = s, distant E = s.

Light forms evaluated in the shaders (Blender's, exactly):
  point/spot  E = I cos(theta) / (d^2 + r^2) with lantern:softFalloff (default), else
              I cos(theta) / d^2. Spot mask smoothstep(0, 1, (cos(phi) - cos(half)) /
              ((1 - cos(half)) * softness)), a hard step when softness = 0.
  sun         E cos(theta).
  rect/disk   diffuse: exact polygon irradiance (Lambert's edge integral, polygon
              clipped to the receiver's upper hemisphere), the disk as an equal-area
              N-gon. One-sided, emits along the light's -Z. Specular: GGX evaluated
              towards a representative point (the reflection ray's hit on the light
              plane, clamped to the shape) with roughness widened by the light's size,
              times the same irradiance. An approximation, not exact.

Light volumes: a light's volume reaches the distance R where the largest radiance it
can reflect off a white Lambert surface, I_max / (pi R^2), falls below
VOLUME_THRESHOLD = 1e-4 W/(sr m2) (I_max = max channel of I; for area lights I_max =
L * area, the far-field intensity along the normal). Glossy highlights beyond R are
cut off.

No UsdLux prim on the stage at all: a usdview-style default rig, a headlight (a
distant light travelling along the camera's view direction, E = 2.5 W/m2) plus a
uniform grey dome of radiance 0.2 W/(sr m2): a white Lambert surface facing the camera
reads 2.5/pi + 0.2 ~ 1.0.

Dome: uniform colour x intensity, or a lat-long `inputs:texture:file` (times colour x
intensity). Lat-long mapping as Hydra Storm's: in the dome's frame +Y is up (image
top), u = (atan2(z, x) + pi/2) / 2pi. Its diffuse lighting is order-2 spherical
harmonics irradiance computed here with numpy; the map itself is the background.

Stage metersPerUnit does not scale lighting: like Cycles, distances are taken in scene
units."""
from __future__ import annotations

import math
import os

import numpy as np
from pxr import Usd, UsdLux

from .scene import Dome, Light

VOLUME_THRESHOLD = 1e-4
HEADLIGHT_IRRADIANCE = 2.5
DEFAULT_DOME_RADIANCE = 0.2
SUPPORTED = ("SphereLight", "DistantLight", "RectLight", "DiskLight", "DomeLight")


def is_light(prim: Usd.Prim) -> bool:
    return prim.HasAPI(UsdLux.LightAPI)


def _get(prim, name, default, time):
    attr = prim.GetAttribute(name)
    if attr and attr.HasValue():
        v = attr.Get(time)
        if v is not None:
            return v
    return default


def _axis_lengths(world):
    return np.linalg.norm(world[:3, :3], axis=0)


def _unit(v):
    n = np.linalg.norm(v)
    return v / n if n > 1e-30 else v


def read_light(prim: Usd.Prim, world: np.ndarray, time, warnings: list):
    """A Light record, a Dome, or None (unsupported, with a warning)."""
    tname = prim.GetTypeName()
    path = str(prim.GetPath())
    api = UsdLux.LightAPI(prim)
    intensity = float(api.GetIntensityAttr().Get(time) or 0.0)
    exposure = float(api.GetExposureAttr().Get(time) or 0.0)
    color = np.array(api.GetColorAttr().Get(time) or (1, 1, 1), dtype=np.float64)
    normalize = bool(api.GetNormalizeAttr().Get(time))
    s = intensity * 2.0 ** exposure * color
    diffuse = float(_get(prim, "inputs:diffuse", 1.0, time))
    specular = float(_get(prim, "inputs:specular", 1.0, time))
    shadow = bool(_get(prim, "inputs:shadow:enable", True, time))
    shadow_res = int(_get(prim, "lantern:shadowResolution", 0, time) or 0)
    scale = _axis_lengths(world)
    pos = world[:3, 3].copy()
    axis = _unit(-world[:3, 2])
    common = dict(name=path, position=pos, axis=axis, x_axis=_unit(world[:3, 0]),
                  y_axis=_unit(world[:3, 1]), diffuse=diffuse, specular=specular, shadow=shadow,
                  shadow_resolution=shadow_res)

    if tname == "SphereLight":
        radius = float(_get(prim, "inputs:radius", 0.5, time)) * float(np.mean(scale))
        point = bool(_get(prim, "treatAsPoint", False, time)) or radius <= 0
        if normalize:
            I = s / 4.0
        else:
            I = s if point else s * math.pi * radius * radius
        cone = float(_get(prim, "inputs:shaping:cone:angle", 90.0, time))
        soft = float(_get(prim, "inputs:shaping:cone:softness", 0.0, time))
        kind = "spot" if prim.HasAPI(UsdLux.ShapingAPI) and cone < 90.0 else "sphere"
        return Light(kind=kind, color=I, radius=0.0 if point else radius,
                     soft_falloff=bool(_get(prim, "lantern:softFalloff", True, time)),
                     cone_angle=cone, cone_softness=max(soft, 0.0), **common)
    if tname == "DistantLight":
        return Light(kind="distant", color=s, angle=float(_get(prim, "inputs:angle", 0.53, time)),
                     **common)
    if tname == "RectLight":
        w = float(_get(prim, "inputs:width", 1.0, time)) * scale[0]
        h = float(_get(prim, "inputs:height", 1.0, time)) * scale[1]
        area = max(w * h, 1e-12)
        return Light(kind="rect", color=s / area if normalize else s, width=w, height=h, **common)
    if tname == "DiskLight":
        r = float(_get(prim, "inputs:radius", 0.5, time)) * float(np.mean(scale[:2]))
        area = max(math.pi * r * r, 1e-12)
        return Light(kind="disk", color=s / area if normalize else s, radius=r, **common)
    if tname == "DomeLight":
        return read_dome(prim, world, s, time, warnings)
    warnings.append(f"{path}: light type {tname or 'untyped'} is not supported; skipped")
    return None


def read_dome(prim, world, radiance, time, warnings) -> Dome:
    path = str(prim.GetPath())
    rot = world[:3, :3] / np.maximum(_axis_lengths(world), 1e-30)
    tex = None
    attr = prim.GetAttribute("inputs:texture:file")
    asset = attr.Get(time) if attr else None
    if asset is not None and asset.path:
        resolved = asset.resolvedPath
        if resolved and os.path.isfile(resolved):
            tex = resolved
        else:
            warnings.append(f"{path}: dome texture {asset.path!r} not found; "
                            f"using the uniform colour")
    sh = uniform_sh(radiance)
    if tex is not None:
        try:
            img = load_latlong(tex)
            sh = latlong_sh(img, rot) * radiance[None, :]
        except Exception as exc:  # unreadable image: same fallback as missing
            warnings.append(f"{path}: dome texture {tex!r} unreadable ({exc}); "
                            f"using the uniform colour")
            tex = None
    return Dome(name=path, radiance=np.asarray(radiance, float), sh=sh, texture=tex, rotation=rot)


def default_dome() -> Dome:
    rad = np.full(3, DEFAULT_DOME_RADIANCE)
    return Dome(name="<default dome>", radiance=rad, sh=uniform_sh(rad))


def headlight(view_forward: np.ndarray) -> Light:
    return Light(kind="distant", name="<headlight>", color=np.full(3, HEADLIGHT_IRRADIANCE),
                 axis=_unit(np.asarray(view_forward, float)), shadow=False)


# --- order-2 spherical harmonics -------------------------------------------------
# Irradiance E(n) = sum_lm A_l L_lm Y_lm(n) (Ramamoorthi & Hanrahan 2001). The
# coefficients handed to the shader already include A_l, so the shader only
# evaluates the basis; sh_basis here and sh_irradiance in lib.glsl must agree.
_A = np.array([math.pi] + [2 * math.pi / 3] * 3 + [math.pi / 4] * 5)


def sh_basis(d: np.ndarray) -> np.ndarray:
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, 0.282095),
        0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1),
        1.092548 * x * z, 0.546274 * (x * x - y * y)], axis=-1)


def uniform_sh(radiance) -> np.ndarray:
    sh = np.zeros((9, 3))
    sh[0] = np.asarray(radiance, float) * 4 * math.pi * 0.282095 * _A[0]
    return sh


def load_latlong(path: str) -> np.ndarray:
    from .textures import read_image_linear
    img = read_image_linear(path, "auto")[..., :3]
    # A few thousand samples are plenty for order-2 harmonics.
    step = max(1, img.shape[1] // 256)
    return img[::step, ::step].astype(np.float64)


def latlong_dirs(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Dome-frame directions of pixel centres (row 0 = top = +Y) and solid angles."""
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2 * math.pi - math.pi / 2
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)], axis=-1)
    dw = (2 * math.pi / w) * (math.pi / h) * np.sin(th)
    return d, dw


def latlong_sh(img_pair, rotation: np.ndarray) -> np.ndarray:
    img = img_pair
    h, w = img.shape[:2]
    d, dw = latlong_dirs(h, w)
    d = d @ rotation.T
    Y = sh_basis(d)                                   # (h, w, 9)
    L = np.einsum("hwk,hwc,hw->kc", Y, img, dw)       # projection of radiance
    return L * _A[:, None]


def volume_radius(light: Light) -> float:
    """Distance beyond which the light reflects < VOLUME_THRESHOLD off white Lambert."""
    c = float(np.max(light.color)) * max(light.diffuse, light.specular, 0.0)
    if light.kind in ("rect", "disk"):
        area = light.width * light.height if light.kind == "rect" else math.pi * light.radius ** 2
        c *= area
        extent = math.hypot(light.width, light.height) / 2 if light.kind == "rect" else light.radius
    else:
        extent = light.radius
    if c <= 0:
        return 0.0
    return math.sqrt(c / (math.pi * VOLUME_THRESHOLD)) + extent
