"""Cameras and render settings on the stage: UsdGeom.Camera -> Camera records (OpenGL
clip space, column-vector numpy), the camera a render uses, its image size and time.

The aperture is conformed to the image aspect like Blender's sensor fit AUTO (see
engine/view.py, which also frames stages without a camera)."""
from __future__ import annotations

import math

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdRender

from ...core.transforms import frustum, ortho
from ..bounces import Bounces
from ..view import camera, conform
from .validate import NOT_FINITE, unfit_items

DEFAULT_SIZE = (640, 360)
RENDER_SETTINGS = "/Render/Settings"


def gf_to_np(m) -> np.ndarray:
    """Gf.Matrix4d (row-vector convention) -> column-vector numpy matrix."""
    return np.array(m, dtype=np.float64).T


class CameraError(ValueError):
    """A camera that cannot make an image (zero, negative or non-finite lens values,
    clipping range or transform, an unknown projection): the message names the prim."""


def _finite(*values) -> bool:
    return all(math.isfinite(float(v)) for v in values)


def camera_from_usd(prim: Usd.Prim, time, aspect: float, xcache=None):
    path = str(prim.GetPath())
    camera_schema = UsdGeom.Camera(prim)
    projection = camera_schema.GetProjectionAttr().Get(time)
    if projection not in (UsdGeom.Tokens.perspective, UsdGeom.Tokens.orthographic):
        raise CameraError(f"{path}: unknown projection {projection!r} "
                          f"(perspective or orthographic)")
    gfcam = camera_schema.GetCamera(time)
    world = gf_to_np(xcache.GetLocalToWorldTransform(prim)) if xcache else gf_to_np(gfcam.transform)
    if unfit_items(world).any():
        raise CameraError(f"{path}: its transform is {NOT_FINITE}")
    if abs(np.linalg.det(world[:3, :3])) <= 1e-300:
        raise CameraError(f"{path}: its transform is singular (a zero scale)")
    h_ap, v_ap = gfcam.horizontalAperture, gfcam.verticalAperture
    h_off, v_off = gfcam.horizontalApertureOffset, gfcam.verticalApertureOffset
    if not _finite(h_ap, v_ap, h_off, v_off) or h_ap < 0 or v_ap < 0:
        raise CameraError(f"{path}: apertures must be finite and positive "
                          f"(horizontal {h_ap:g}, vertical {v_ap:g})")
    h_ap, v_ap = conform(h_ap, v_ap, aspect)
    if not (h_ap > 0 and v_ap > 0):
        raise CameraError(f"{path}: a zero aperture (horizontal {gfcam.horizontalAperture:g}, "
                          f"vertical {gfcam.verticalAperture:g}) sees nothing")
    clip = gfcam.clippingRange
    near, far = float(clip.min), float(clip.max)
    if not _finite(near, far) or near < 0 or far <= near:
        raise CameraError(f"{path}: clippingRange ({near:g}, {far:g}) must be finite with "
                          f"0 <= near < far")
    # A near plane at 0 would put every depth at infinity: take it a little off the eye,
    # relative to the far plane (reversed float depth is precise there anyway).
    if near == 0:
        near = far * 1e-7
    is_ortho = projection == UsdGeom.Tokens.orthographic
    if is_ortho:
        # Apertures are in tenths of a scene unit (USD's convention).
        s = 0.1
        proj = ortho((-h_ap / 2 + h_off) * s, (h_ap / 2 + h_off) * s,
                     (-v_ap / 2 + v_off) * s, (v_ap / 2 + v_off) * s, near, far)
    else:
        focal = gfcam.focalLength
        if not _finite(focal) or focal <= 0:
            raise CameraError(f"{path}: focalLength {focal:g} must be finite and positive")
        k = near / focal
        proj = frustum((-h_ap / 2 + h_off) * k, (h_ap / 2 + h_off) * k,
                       (-v_ap / 2 + v_off) * k, (v_ap / 2 + v_off) * k, near, far)
    if not np.isfinite(proj).all():
        raise CameraError(f"{path}: its lens gives no finite projection")
    return camera(world, proj, near, far, is_ortho, path)


def might_vary(prim: Usd.Prim) -> bool:
    """Whether the camera's transform (or any ancestor's) or its lens may change over
    time."""
    if any(a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()):
        return True
    p = prim
    while p and not p.IsPseudoRoot():
        xf = UsdGeom.Xformable(p)
        if xf and xf.TransformMightBeTimeVarying():
            return True
        p = p.GetParent()
    return False


def settings_camera_path(stage: Usd.Stage, warnings: list | None = None):
    """The /Render/Settings `camera` target when it is a camera, else None (with a
    warning in `warnings` when it names a missing prim or one that is not a camera)."""
    settings = stage.GetPrimAtPath(RENDER_SETTINGS)
    if settings and settings.IsA(UsdRender.Settings):
        for t in UsdRender.Settings(settings).GetCameraRel().GetForwardedTargets():
            p = stage.GetPrimAtPath(t)
            if p and p.IsA(UsdGeom.Camera):
                return str(p.GetPath())
            if warnings is not None:
                what = f"is a {p.GetTypeName() or 'typeless prim'}, not a Camera" if p \
                    else "does not exist"
                warnings.append(f"{RENDER_SETTINGS}: its camera {t} {what}; using the "
                                f"first camera, or the default view")
    return None


def rendered_camera_path(stage: Usd.Stage, camera: str | None = None):
    """The camera a render of `stage` goes through: `camera`, else /Render/Settings',
    else the first camera prim; None when there is none (the engine frames the scene)."""
    path = camera or settings_camera_path(stage)
    if path is None:
        path = next((str(p.GetPath()) for p in stage.Traverse() if is_camera(p)), None)
    return path


def view_settings(stage: Usd.Stage) -> dict:
    """Blender's colour management as the exporter wrote it on /Render/Settings (view,
    look, exposure; docs/stage_contract.md), for display images; {} when absent."""
    prim = stage.GetPrimAtPath(RENDER_SETTINGS)
    out = {}
    if prim and prim.IsA(UsdRender.Settings):
        for key, name in (("view", "lantern:viewTransform"), ("look", "lantern:look"),
                          ("exposure", "lantern:exposure")):
            attr = prim.GetAttribute(name)
            if attr and attr.HasAuthoredValue():
                out[key] = attr.Get()
    return out


# /Render/Settings' bounces (Cycles' Light Paths, docs/stage_contract.md): attribute,
# Bounces field.
BOUNCE_ATTRIBUTES = (("lantern:maxBounces", "total"), ("lantern:diffuseBounces", "diffuse"),
                     ("lantern:glossyBounces", "glossy"))


def bounces(stage: Usd.Stage, warnings: list | None = None):
    """The bounces /Render/Settings asks for (a Bounces; Cycles' default for any of the
    three it leaves out), or None when it names none. A value that is not a whole
    number >= 0 is a warning in `warnings`, and its default is taken."""
    prim = stage.GetPrimAtPath(RENDER_SETTINGS)
    if not (prim and prim.IsA(UsdRender.Settings)):
        return None
    found = {}
    for name, field_name in BOUNCE_ATTRIBUTES:
        attr = prim.GetAttribute(name)
        if not (attr and attr.HasAuthoredValue()):
            continue
        value = attr.Get()
        if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
            found[field_name] = value
        elif warnings is not None:
            warnings.append(f"{RENDER_SETTINGS}: {name} is {value!r}, not a whole number "
                            f">= 0; Cycles' default is taken")
    return Bounces(**found) if found else None


def camera_path_problem(stage: Usd.Stage, path: str, scene_name: str):
    """Why `path` cannot be the camera to render through (`scene_name` names the
    stage's file), or None when it is a Camera prim."""
    if not Sdf.Path.IsValidPathString(path):
        return "not a valid prim path"
    prim = stage.GetPrimAtPath(path)
    if not prim:
        return f"{scene_name} has no such prim"
    if not prim.IsA(UsdGeom.Camera):
        return f"is a {prim.GetTypeName() or 'typeless prim'}, not a Camera"
    return None


def is_camera(prim: Usd.Prim) -> bool:
    return prim.IsA(UsdGeom.Camera)


def resolution(stage: Usd.Stage, width, height):
    """(width, height): both given, or the missing ones from /Render/Settings'
    resolution (keeping its aspect), else 640x360."""
    w, h = width, height
    if w is None or h is None:
        res = None
        prim = stage.GetPrimAtPath(RENDER_SETTINGS)
        if prim and prim.IsA(UsdRender.Settings):
            attr = UsdRender.Settings(prim).GetResolutionAttr()
            if attr.HasAuthoredValue():
                res = attr.Get()
        base = (int(res[0]), int(res[1])) if res is not None else DEFAULT_SIZE
        if w is None and h is None:
            w, h = base
        elif w is None:
            w = max(1, round(h * base[0] / base[1]))
        else:
            h = max(1, round(w * base[1] / base[0]))
    if w < 1 or h < 1:
        raise ValueError(f"image size must be positive, got {w}x{h}")
    return int(w), int(h)


def default_time(stage: Usd.Stage):
    """The time a render without a frame uses: startTimeCode if authored, else
    Default (as a float key: None)."""
    if stage.HasAuthoredMetadata("startTimeCode"):
        return float(stage.GetStartTimeCode())
    return None


def time_code(frame) -> Usd.TimeCode:
    return Usd.TimeCode.Default() if frame is None else Usd.TimeCode(frame)
