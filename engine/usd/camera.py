"""Cameras and render settings on the stage: UsdGeom.Camera -> Camera records (OpenGL
clip space, column-vector numpy), the camera a render uses, its image size and time.

The aperture is conformed to the image aspect like Blender's sensor fit AUTO (see
engine/view.py, which also frames stages without a camera)."""
from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdRender

from ...core.transforms import frustum, ortho
from ..view import camera, conform

DEFAULT_SIZE = (640, 360)
RENDER_SETTINGS = "/Render/Settings"


def gf_to_np(m) -> np.ndarray:
    """Gf.Matrix4d (row-vector convention) -> column-vector numpy matrix."""
    return np.array(m, dtype=np.float64).T


def camera_from_usd(prim: Usd.Prim, time, aspect: float, xcache=None):
    gfcam = UsdGeom.Camera(prim).GetCamera(time)
    world = gf_to_np(xcache.GetLocalToWorldTransform(prim)) if xcache else gf_to_np(gfcam.transform)
    h_ap, v_ap = conform(gfcam.horizontalAperture, gfcam.verticalAperture, aspect)
    h_off, v_off = gfcam.horizontalApertureOffset, gfcam.verticalApertureOffset
    clip = gfcam.clippingRange
    near, far = max(float(clip.min), 1e-6), float(clip.max)
    if far <= near:
        far = near * 1e4
    is_ortho = gfcam.projection == Gf.Camera.Orthographic
    if is_ortho:
        # Apertures are in tenths of a scene unit (USD's convention).
        s = 0.1
        proj = ortho((-h_ap / 2 + h_off) * s, (h_ap / 2 + h_off) * s,
                     (-v_ap / 2 + v_off) * s, (v_ap / 2 + v_off) * s, near, far)
    else:
        k = near / gfcam.focalLength
        proj = frustum((-h_ap / 2 + h_off) * k, (h_ap / 2 + h_off) * k,
                       (-v_ap / 2 + v_off) * k, (v_ap / 2 + v_off) * k, near, far)
    return camera(world, proj, near, far, is_ortho, str(prim.GetPath()))


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


def settings_camera_path(stage: Usd.Stage):
    """The /Render/Settings `camera` target when it is a camera, else None."""
    settings = stage.GetPrimAtPath(RENDER_SETTINGS)
    if settings and settings.IsA(UsdRender.Settings):
        for t in UsdRender.Settings(settings).GetCameraRel().GetForwardedTargets():
            p = stage.GetPrimAtPath(t)
            if p and p.IsA(UsdGeom.Camera):
                return str(p.GetPath())
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
