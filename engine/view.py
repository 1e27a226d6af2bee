"""Cameras as matrices, and what they see: OpenGL clip space, column-vector numpy.

The default view (a stage without a camera) looks at the centre of what is drawn at
the render time (posed skinned meshes, blend shapes, time-sampled points: the GL
side measures them) from an elevated three-quarter direction, (+1, -1, +1) in a Z-up
stage and (+1, +1, +1) in a Y-up one: 35 degrees above the ground and never along
an axis, so no axis-aligned flat scene is seen edge-on. Blender's default lens (50 mm
on a 36 mm sensor), at the distance where the bounding sphere fits the narrower field
of view (plus 5 %). An empty stage frames the unit cube.

Apertures are conformed to the image aspect like Blender's sensor fit AUTO: the larger
image dimension keeps its field of view."""
from __future__ import annotations

import math

import numpy as np

from ..core.transforms import frustum, look_at
from .scene import Camera


def conform(h_ap, v_ap, aspect):
    """Blender sensor fit AUTO: the larger image dimension keeps its aperture."""
    if aspect >= 1.0:
        return h_ap, h_ap / aspect
    return v_ap * aspect, v_ap


def camera(world, proj, near, far, is_ortho, name) -> Camera:
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
    return camera(np.linalg.inv(view), proj, float(near), float(far), is_ortho, "<view>")


def default_camera(bounds, up_axis: str, aspect: float) -> Camera:
    """The default view of `bounds` ((lo, hi) world box, or None: nothing drawn)."""
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
    return camera(world, proj, near, far, False, "<default camera>")


def frustum_planes(view_proj) -> np.ndarray:
    """Gribb-Hartmann: the six planes (a, b, c, d), inside when a x + b y + c z + d >= 0."""
    m = view_proj
    planes = np.array([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1],
                       m[3] + m[2], m[3] - m[2]])
    return planes / np.maximum(np.linalg.norm(planes[:, :3], axis=1, keepdims=True), 1e-30)


def boxes_outside(planes, lo, hi) -> np.ndarray:
    """(n,) bool: boxes (n, 3) wholly outside one plane, so outside the frustum."""
    # Per plane, the corner furthest along its normal.
    p = np.where(planes[None, :, :3] >= 0, hi[:, None, :], lo[:, None, :])
    return np.any(np.einsum("pj,npj->np", planes[:, :3], p) + planes[:, 3] < 0, axis=1)
