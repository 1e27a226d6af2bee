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
              N-gon. One-sided, emits along the light's -Z. Specular: the GGX lobes'
              share of the same polygon by linearly transformed cosines
              (shaders/ltc.glsl, engine/ltc.py) times their albedo: the lobe's shape
              is fitted, its Fresnel averaged over it.

Dome: uniform colour x intensity, or a lat-long `inputs:texture:file` (times colour x
intensity). A map's irradiance harmonics and prefiltered reflections are made once
per map on the GL side (engine/gpu/environment.py), not here at every read.

Stage metersPerUnit does not scale lighting: like Cycles, distances are taken in scene
units."""
from __future__ import annotations

import math
import os

import numpy as np
from pxr import Usd, UsdLux

from ...core.lights import DISK, POINT, RECT, SPOT, SUN, kind_of_usd
from ..lighting import uniform_sh
from ..scene import Dome, Light
from .validate import NOT_FINITE, fits


def is_light(prim: Usd.Prim) -> bool:
    return prim.HasAPI(UsdLux.LightAPI)


# The schemas' fallbacks of every input a light reads (UsdLux 25.08), and Lantern's own:
# a light reads its authored attributes once (light_values) and takes these for the rest.
FALLBACKS = {
    "inputs:intensity": 1.0, "inputs:exposure": 0.0, "inputs:color": (1.0, 1.0, 1.0),
    "inputs:normalize": False, "inputs:diffuse": 1.0, "inputs:specular": 1.0,
    "inputs:shadow:enable": True, "inputs:radius": 0.5, "treatAsPoint": False,
    "inputs:shaping:cone:angle": 90.0, "inputs:shaping:cone:softness": 0.0,
    "inputs:angle": 0.53, "inputs:width": 1.0, "inputs:height": 1.0,
    "lantern:shadowResolution": 0, "lantern:softFalloff": True, "lantern:aoDistance": None,
}


INPUTS = set(FALLBACKS) | {"inputs:texture:file"}          # what a light reads


def light_values(prim: Usd.Prim, time) -> tuple[dict, list]:
    """({input name: value} of the light's authored inputs at `time`, the names of its
    authored xform ops, for the reader, whose concern its transform is): one pass over
    its authored attributes, so a stage of many lights costs a few calls a light."""
    values, ops = {}, []
    for attr in prim.GetAuthoredAttributes():
        name = attr.GetName()
        if name.startswith("xformOp:"):
            ops.append(name)
        elif name in INPUTS:
            value = attr.Get(time)
            if value is not None:
                values[name] = value
    return values, ops


def light_varies(prim: Usd.Prim) -> bool:
    """Whether an input the light reads, or an xform op of its own, may change over
    time (its ancestors' transforms are the reader's concern)."""
    return any(attr.ValueMightBeTimeVarying() for attr in prim.GetAuthoredAttributes()
               if attr.GetName().startswith("xformOp:") or attr.GetName() in INPUTS)


def _number(values, name, **checks) -> float:
    """An input as a float, checked (_valid) where authored: a fallback is valid."""
    if name not in values:
        return float(FALLBACKS[name])
    return float(_valid(values[name], name, **checks))


# A light's numbers are a handful of floats: Python arithmetic on them costs a tenth
# of numpy's per-call overhead, which a stage of 16,384 lights pays 16,384 times.
# Arrays are made once, for the record.
def _length(v) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def _columns(m) -> tuple:
    """A world matrix's (nested lists, m[row][column]) four columns: its axes and its
    position."""
    (a, b, c, d), (e, f, g, h), (i, j, k, l) = m[0], m[1], m[2]
    return (a, e, i), (b, f, j), (c, g, k), (d, h, l)


def _axis_lengths(m) -> tuple:
    """The lengths of a world matrix's three axes."""
    x, y, z, _ = _columns(m)
    return _length(x), _length(y), _length(z)


def _unit(v, n) -> tuple:
    """v over its length n (v itself when that is 0)."""
    return (v[0] / n, v[1] / n, v[2] / n) if n > 1e-30 else tuple(v)


class _Bad(ValueError):
    """A light value no light can have: the light is dropped with a warning."""


def _valid(value, what, positive=False, nonneg=False):
    """value (float or sequence) if finite in float32 (validate.py; and > 0 / >= 0 as
    asked), else _Bad."""
    items = (float(value),) if isinstance(value, (int, float)) else tuple(map(float, value))
    if not all(map(fits, items)):
        raise _Bad(f"{what} is {_show(value)}, {NOT_FINITE}")
    if positive and min(items) <= 0:          # no NaN past the line above
        raise _Bad(f"{what} is {_show(value)}, not positive")
    if nonneg and min(items) < 0:
        raise _Bad(f"{what} is {_show(value)}, negative")
    return value


def _show(value):
    arr = np.atleast_1d(np.asarray(value, np.float64))
    return f"{arr[0]:g}" if arr.size == 1 else "(" + ", ".join(f"{v:g}" for v in arr) + ")"


def _scale(values) -> tuple:
    """intensity * 2^exposure * color of the light's authored `values` (the checks of
    _number where authored), or _Bad when it overflows."""
    intensity = float(values.get("inputs:intensity", 1.0) or 0.0)
    exposure = float(values.get("inputs:exposure", 0.0) or 0.0)
    color = tuple(map(float, values.get("inputs:color", (1.0, 1.0, 1.0))))
    if "inputs:intensity" in values:
        _valid(intensity, "inputs:intensity", nonneg=True)
    if "inputs:exposure" in values:
        _valid(exposure, "inputs:exposure")
    if "inputs:color" in values:
        _valid(color, "inputs:color", nonneg=True)
    try:
        gain = 2.0 ** exposure
    except OverflowError:
        gain = math.inf
    s = tuple(intensity * gain * c for c in color)
    if not all(map(fits, s)):
        raise _Bad(f"inputs:intensity {intensity:g} x 2^inputs:exposure {exposure:g} x "
                   f"inputs:color is {NOT_FINITE}")
    return s


def _over(s, d) -> tuple:
    """s / d in Python floats: an overflow is Inf, refused by _light, not numpy's warning."""
    return (s[0] / d, s[1] / d, s[2] / d)


MADE = ("color", "radius", "width", "height")    # a Light's numbers made from others


def _light(**fields) -> Light:
    """A Light record, once the numbers made from its inputs and transform (its
    radiometric colour, its sizes times its scale) are finite in float32 too."""
    if not all(map(fits, (*fields["color"], *(fields.get(n, 0.0) for n in MADE[1:])))):
        for name in MADE:                 # name the first that is not
            if name in fields:
                _valid(fields[name], f"its {name} after its transform and normalization")
    fields["color"] = np.array(fields["color"])
    return Light(**fields)


def read_light(prim: Usd.Prim, path: str, world: np.ndarray, values: dict, warnings: list):
    """A Light record, a Dome, or None (unsupported or invalid, with a warning), from
    the light's authored `values` (light_values); `path`: the prim's."""
    try:
        return _read_light(prim, path, world, values, warnings)
    except _Bad as bad:
        warnings.append(f"{path}: {bad}; light dropped")
        return None


def _read_light(prim, path, world, values, warnings):
    tname = prim.GetTypeName()
    v = {**FALLBACKS, **values}
    normalize = bool(v["inputs:normalize"])
    if not fits(float(np.abs(world).max())):             # NaN (all of it), Inf, too large
        raise _Bad(f"its transform is {NOT_FINITE}")
    s = _scale(values)
    if tname == "DomeLight":
        return read_dome(prim, world, np.array(s), values, warnings)
    x_col, y_col, z_col, pos = _columns(world.tolist())
    scale = (_length(x_col), _length(y_col), _length(z_col))
    common = dict(name=path, position=np.array(pos),
                  axis=np.array(_unit((-z_col[0], -z_col[1], -z_col[2]), scale[2])),
                  x_axis=np.array(_unit(x_col, scale[0])),
                  y_axis=np.array(_unit(y_col, scale[1])),
                  diffuse=_number(values, "inputs:diffuse"),
                  specular=_number(values, "inputs:specular"),
                  shadow=bool(v["inputs:shadow:enable"]),
                  shadow_resolution=int(v["lantern:shadowResolution"] or 0))
    # Only an authored cone angle (below 90) can make a spot: the API is asked then.
    shaped = "inputs:shaping:cone:angle" in values and prim.HasAPI(UsdLux.ShapingAPI)
    cone = float(v["inputs:shaping:cone:angle"])
    if shaped:
        _valid(cone, "inputs:shaping:cone:angle", positive=True)
    kind = kind_of_usd(tname, spot=shaped and cone < 90.0)

    if kind in (POINT, SPOT):
        radius = _number(values, "inputs:radius", nonneg=True) * (sum(scale) / 3)
        point = bool(v["treatAsPoint"]) or radius <= 0
        if normalize:
            I = _over(s, 4.0)
        else:
            I = s if point else tuple(c * math.pi * radius * radius for c in s)
        soft = _number(values, "inputs:shaping:cone:softness")
        return _light(kind=kind, color=I, radius=0.0 if point else radius,
                      soft_falloff=bool(v["lantern:softFalloff"]),
                      cone_angle=cone, cone_softness=max(soft, 0.0), **common)
    if kind == SUN:
        angle = _number(values, "inputs:angle", nonneg=True)
        return _light(kind=SUN, color=s, angle=angle, **common)
    if kind == RECT:
        w = _number(values, "inputs:width", positive=True)
        h = _number(values, "inputs:height", positive=True)
        w, h = w * scale[0], h * scale[1]
        if not w * h > 0:
            raise _Bad("its transform scales it to no area")
        return _light(kind=RECT, color=_over(s, w * h) if normalize else s,
                      width=w, height=h, **common)
    if kind == DISK:
        # A scale that differs along x and y makes it an ellipse (Blender's ellipse
        # lights are written so: docs/stage_contract.md).
        r = _number(values, "inputs:radius", positive=True)
        rx, ry = r * scale[0], r * scale[1]
        if not rx * ry > 0:
            raise _Bad("its transform scales it to no area")
        return _light(kind=DISK, color=_over(s, math.pi * rx * ry) if normalize else s,
                      radius=max(rx, ry), width=2 * rx, height=2 * ry, **common)
    warnings.append(f"{path}: light type {tname or 'untyped'} is not supported; skipped")
    return None


def read_dome(prim, world, radiance, values, warnings) -> Dome:
    path = str(prim.GetPath())
    rot = world[:3, :3] / np.maximum(_axis_lengths(world.tolist()), 1e-30)
    tex = None
    asset = values.get("inputs:texture:file")
    if asset is not None and asset.path:
        resolved = asset.resolvedPath
        if resolved and os.path.isfile(resolved):
            tex = resolved
        else:
            warnings.append(f"{path}: dome texture {asset.path!r} not found; "
                            f"using the uniform colour")
    distance = values.get("lantern:aoDistance")
    if distance is not None and not (math.isfinite(float(distance)) and float(distance) > 0):
        warnings.append(f"{path}: lantern:aoDistance {distance!r} is not a positive number; "
                        f"using the default")
        distance = None
    return Dome(name=path, radiance=np.asarray(radiance, float), sh=uniform_sh(radiance),
                texture=tex, rotation=rot,
                ao_distance=float(distance) if distance is not None else None)
