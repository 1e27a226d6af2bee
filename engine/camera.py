"""Cameras: UsdGeom.Camera -> view and projection matrices (OpenGL clip space,
column-vector numpy).

The aperture is conformed to the image aspect like Blender's sensor fit AUTO: the
larger image dimension keeps its field of view.

No camera on the stage: the default camera looks at the centre of the scene's world
bounds (UsdGeom.BBoxCache, purposes default+render) from the direction (+1, -1, +1)
in a Z-up stage ((+1, +1, +1) in Y-up), with Blender's default lens (50 mm on a 36 mm
sensor), at the distance where the bounding sphere fits the narrower field of view
(plus 5 %). An empty stage frames the unit cube."""
from __future__ import annotations

import math

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdRender

from .scene import Camera


def gf_to_np(m) -> np.ndarray:
    """Gf.Matrix4d (row-vector convention) -> column-vector numpy matrix."""
    return np.array(m, dtype=np.float64).T


def frustum(l, r, b, t, n, f):
    return np.array([
        [2 * n / (r - l), 0, (r + l) / (r - l), 0],
        [0, 2 * n / (t - b), (t + b) / (t - b), 0],
        [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)],
        [0, 0, -1, 0]], dtype=np.float64)


def ortho(l, r, b, t, n, f):
    return np.array([
        [2 / (r - l), 0, 0, -(r + l) / (r - l)],
        [0, 2 / (t - b), 0, -(t + b) / (t - b)],
        [0, 0, -2 / (f - n), -(f + n) / (f - n)],
        [0, 0, 0, 1]], dtype=np.float64)


def look_at(eye, target, up):
    """The world matrix of a camera at `eye` looking at `target` (its view matrix is
    the inverse)."""
    fwd = target - eye
    fwd /= np.linalg.norm(fwd)
    side = np.cross(fwd, up)
    if np.linalg.norm(side) < 1e-6:  # up along the view: any perpendicular will do
        side = np.cross(fwd, [1.0, 0.0, 0.0] if abs(fwd[0]) < 0.9 else [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    upv = np.cross(side, fwd)
    world = np.eye(4)
    world[:3, 0], world[:3, 1], world[:3, 2], world[:3, 3] = side, upv, -fwd, eye
    return world


def conform(h_ap, v_ap, aspect):
    """Blender sensor fit AUTO: the larger image dimension keeps its aperture."""
    if aspect >= 1.0:
        return h_ap, h_ap / aspect
    return v_ap * aspect, v_ap


def camera_from_usd(prim: Usd.Prim, time, aspect: float, xcache=None) -> Camera:
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
    return _camera(world, proj, near, far, is_ortho, str(prim.GetPath()))


def _camera(world, proj, near, far, is_ortho, name):
    fwd = -world[:3, 2]
    fwd = fwd / max(np.linalg.norm(fwd), 1e-30)
    return Camera(view=np.linalg.inv(world), proj=proj, position=world[:3, 3].copy(),
                  forward=fwd, near=near, far=far, ortho=is_ortho, name=name)


def camera_from_matrices(view, proj) -> Camera:
    """A camera given as OpenGL view and projection matrices (e.g. Blender's viewport)."""
    view, proj = np.asarray(view, np.float64), np.asarray(proj, np.float64)
    is_ortho = abs(proj[3, 3] - 1.0) < 1e-9
    if is_ortho:
        near, far = (proj[2, 3] + 1) / proj[2, 2], (proj[2, 3] - 1) / proj[2, 2]
    else:
        near, far = proj[2, 3] / (proj[2, 2] - 1), proj[2, 3] / (proj[2, 2] + 1)
    return _camera(np.linalg.inv(view), proj, float(near), float(far), is_ortho, "<view>")


def default_camera(bounds, up_axis: str, aspect: float) -> Camera:
    if bounds is None:
        lo, hi = np.full(3, -1.0), np.full(3, 1.0)
    else:
        lo, hi = np.asarray(bounds[0], float), np.asarray(bounds[1], float)
    center = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-3)
    if up_axis == "Y":
        direction, up = np.array([1.0, 1.0, 1.0]), np.array([0.0, 1.0, 0.0])
    else:
        direction, up = np.array([1.0, -1.0, 1.0]), np.array([0.0, 0.0, 1.0])
    direction /= np.linalg.norm(direction)
    h_ap, v_ap = conform(36.0, 36.0, aspect)
    focal = 50.0
    half_fov = min(math.atan(h_ap / 2 / focal), math.atan(v_ap / 2 / focal))
    dist = radius / math.sin(half_fov) * 1.05
    near, far = max(dist - radius * 1.1, dist * 1e-3), dist + radius * 1.1
    world = look_at(center + direction * dist, center, up)
    k = near / focal
    proj = frustum(-h_ap / 2 * k, h_ap / 2 * k, -v_ap / 2 * k, v_ap / 2 * k, near, far)
    return _camera(world, proj, near, far, False, "<default camera>")


def active_camera_prim(stage: Usd.Stage):
    """/Render/Settings `camera` target, else the first camera found, else None."""
    settings = stage.GetPrimAtPath("/Render/Settings")
    if settings and settings.IsA(UsdRender.Settings):
        targets = UsdRender.Settings(settings).GetCameraRel().GetForwardedTargets()
        for t in targets:
            p = stage.GetPrimAtPath(t)
            if p and p.IsA(UsdGeom.Camera):
                return p
    for p in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()):
        if p.IsA(UsdGeom.Camera) and not p.IsAbstract():
            return p
    return None
