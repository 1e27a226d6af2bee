"""UsdLux lights -> Light and Dome records in Lantern's radiometric convention (see the
stage contract: 1 nit = 1 W/(sr m2)). Kinds come from core.lights, the one table.

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

Dome: uniform colour x intensity, or a lat-long `inputs:texture:file` (times colour x
intensity); engine/lighting.py computes its irradiance harmonics.

Stage metersPerUnit does not scale lighting: like Cycles, distances are taken in scene
units."""
from __future__ import annotations

import math
import os

import numpy as np
from pxr import Usd, UsdLux

from ...core.lights import DISK, POINT, RECT, SPOT, SUN, kind_of_usd
from ..lighting import latlong_sh, load_latlong, uniform_sh
from ..scene import Dome, Light


def is_light(prim: Usd.Prim) -> bool:
    return prim.HasAPI(UsdLux.LightAPI)


def might_vary(prim: Usd.Prim) -> bool:
    """Whether any of the light's own values may change over time (its transform is
    the reader's concern)."""
    return any(a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()
               if not a.GetName().startswith("xformOp"))


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


class _Bad(ValueError):
    """A light value no light can have: the light is dropped with a warning."""


def _valid(value, what, ok="finite", positive=False, nonneg=False):
    """value (float or sequence) if finite (and > 0 / >= 0 as asked), else _Bad."""
    arr = np.atleast_1d(np.asarray(value, np.float64))
    if not np.isfinite(arr).all():
        raise _Bad(f"{what} is {_show(value)}")
    if positive and not (arr > 0).all():
        raise _Bad(f"{what} is {_show(value)}, not positive")
    if nonneg and not (arr >= 0).all():
        raise _Bad(f"{what} is {_show(value)}, negative")
    return value


def _show(value):
    arr = np.atleast_1d(np.asarray(value, np.float64))
    return f"{arr[0]:g}" if arr.size == 1 else "(" + ", ".join(f"{v:g}" for v in arr) + ")"


def _scale(intensity, exposure, color):
    """intensity * 2^exposure * color, or _Bad when it overflows."""
    _valid(intensity, "inputs:intensity", nonneg=True)
    _valid(exposure, "inputs:exposure")
    _valid(color, "inputs:color", nonneg=True)
    try:
        gain = 2.0 ** exposure
    except OverflowError:
        gain = math.inf
    s = intensity * gain * color
    if not np.isfinite(s).all():
        raise _Bad(f"inputs:intensity {intensity:g} x 2^inputs:exposure {exposure:g} overflows")
    return s


def read_light(prim: Usd.Prim, world: np.ndarray, time, warnings: list):
    """A Light record, a Dome, or None (unsupported or invalid, with a warning)."""
    path = str(prim.GetPath())
    try:
        return _read_light(prim, world, time, warnings)
    except _Bad as bad:
        warnings.append(f"{path}: {bad}; light dropped")
        return None


def _read_light(prim, world, time, warnings):
    tname = prim.GetTypeName()
    path = str(prim.GetPath())
    api = UsdLux.LightAPI(prim)
    intensity = float(api.GetIntensityAttr().Get(time) or 0.0)
    exposure = float(api.GetExposureAttr().Get(time) or 0.0)
    color = np.array(api.GetColorAttr().Get(time) or (1, 1, 1), dtype=np.float64)
    normalize = bool(api.GetNormalizeAttr().Get(time))
    if not np.isfinite(world).all():
        raise _Bad("its transform is not finite")
    s = _scale(intensity, exposure, color)
    if tname == "DomeLight":
        return read_dome(prim, world, s, time, warnings)
    diffuse = float(_valid(_get(prim, "inputs:diffuse", 1.0, time), "inputs:diffuse"))
    specular = float(_valid(_get(prim, "inputs:specular", 1.0, time), "inputs:specular"))
    shadow = bool(_get(prim, "inputs:shadow:enable", True, time))
    shadow_res = int(_get(prim, "lantern:shadowResolution", 0, time) or 0)
    scale = _axis_lengths(world)
    pos = world[:3, 3].copy()
    axis = _unit(-world[:3, 2])
    common = dict(name=path, position=pos, axis=axis, x_axis=_unit(world[:3, 0]),
                  y_axis=_unit(world[:3, 1]), diffuse=diffuse, specular=specular, shadow=shadow,
                  shadow_resolution=shadow_res)
    shaped = prim.HasAPI(UsdLux.ShapingAPI)
    cone = float(_get(prim, "inputs:shaping:cone:angle", 90.0, time))
    if shaped:
        _valid(cone, "inputs:shaping:cone:angle", positive=True)
    kind = kind_of_usd(tname, spot=shaped and cone < 90.0)

    if kind in (POINT, SPOT):
        radius = float(_valid(_get(prim, "inputs:radius", 0.5, time), "inputs:radius",
                              nonneg=True)) * float(np.mean(scale))
        point = bool(_get(prim, "treatAsPoint", False, time)) or radius <= 0
        if normalize:
            I = s / 4.0
        else:
            I = s if point else s * math.pi * radius * radius
        soft = float(_valid(_get(prim, "inputs:shaping:cone:softness", 0.0, time),
                            "inputs:shaping:cone:softness"))
        return Light(kind=kind, color=I, radius=0.0 if point else radius,
                     soft_falloff=bool(_get(prim, "lantern:softFalloff", True, time)),
                     cone_angle=cone, cone_softness=max(soft, 0.0), **common)
    if kind == SUN:
        angle = float(_valid(_get(prim, "inputs:angle", 0.53, time), "inputs:angle", nonneg=True))
        return Light(kind=SUN, color=s, angle=angle, **common)
    if kind == RECT:
        w = float(_valid(_get(prim, "inputs:width", 1.0, time), "inputs:width", positive=True))
        h = float(_valid(_get(prim, "inputs:height", 1.0, time), "inputs:height", positive=True))
        w, h = w * scale[0], h * scale[1]
        if not w * h > 0:
            raise _Bad("its transform scales it to no area")
        return Light(kind=RECT, color=s / (w * h) if normalize else s, width=w, height=h, **common)
    if kind == DISK:
        r = float(_valid(_get(prim, "inputs:radius", 0.5, time), "inputs:radius",
                         positive=True)) * float(np.mean(scale[:2]))
        if not r > 0:
            raise _Bad("its transform scales it to no area")
        return Light(kind=DISK, color=s / (math.pi * r * r) if normalize else s, radius=r, **common)
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
