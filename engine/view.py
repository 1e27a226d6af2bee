"""Cameras as matrices, and what they see: OpenGL clip space, column-vector numpy.

The default view (a stage without a camera) looks at the centre of what is drawn at
the render time (posed skinned meshes, blend shapes, time-sampled points: the GL
side measures them) from an elevated three-quarter direction, (+1, -1, +1) in a Z-up
stage and (+1, +1, +1) in a Y-up one: 35 degrees above the ground and never along
an axis, so no axis-aligned flat scene is seen edge-on. Blender's default lens (50 mm
on a 36 mm sensor), at the distance where the bounding sphere fits the narrower field
of view (plus 5 %). An empty stage frames the unit cube.

Apertures are conformed to the image aspect like Blender's sensor fit AUTO: the larger
image dimension keeps its field of view.

The depth convention (every pass and shader follows it; shaders read depth only
through lib.glsl's helpers):
  camera-relative   positions reach the GPU relative to the camera, as Unreal's
                    "translated world" and Filament do: world axes, origin at the eye.
                    Translations are split into two float32s (hi + lo, ~48 bits) on
                    the CPU in double precision; the shader subtracts the eye's pair
                    (shaders/origin.glsl), so a vertex 1e6 m from the world origin is
                    as precise as one at the origin, and a view change uploads no
                    object matrices. The view matrix is then a rotation.
  reversed Z        depth is a 32-bit float, 1 at the near plane and 0 at an
                    infinite far plane (n / d for perspective), cleared to 0, tested
                    GREATER: float's exponent then keeps a nearly constant relative
                    precision (~6e-8 d) at every distance. With GL 4.5's
                    glClipControl(LOWER_LEFT, ZERO_TO_ONE) the projection writes n / d
                    directly; without it (GL 3.3 to 4.4, macOS) the same window depth
                    comes through NDC [-1, 1] as 2n/d - 1, whose rounding near -1 limits
                    it to ~6e-8 absolute in n / d (see docs/status.md, measured).
  far clip          the camera's far plane still clips, as USD's clippingRange asks,
                    by a clip distance rather than by the depth range; culling uses
                    the finite frustum (as Filament's culling projection).
  window matrix     one matrix maps camera-relative positions to (x, y in [0, 1],
                    window depth), whatever the GL's clip convention; its inverse
                    is what position_from_depth uses."""
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


def split_double(v):
    """float64 values -> (hi, lo) float32 with hi + lo == v to ~48 bits: how positions
    far from the origin travel to the GPU (camera-relative rendering)."""
    v = np.asarray(v, np.float64)
    hi = v.astype(np.float32)
    lo = (v - hi.astype(np.float64)).astype(np.float32)
    return hi, lo


def translate(t) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = t
    return m


def relative_view(cam) -> np.ndarray:
    """The camera's world-to-view rotation: its view matrix acting on camera-relative
    positions (p - eye), so translation-free."""
    v = np.array(cam.view, np.float64)
    v = v @ translate(cam.position)
    v[:3, 3] = 0.0
    return v


def _is_ortho(proj) -> bool:
    return abs(proj[3, 3] - 1.0) < 1e-9 and abs(proj[3, 2]) < 1e-12


def window_depth_row(cam) -> np.ndarray:
    """The projection row whose z / w is the window depth: n / d for a perspective
    camera (reversed, infinite far), (far - d) / (far - near) for an orthographic one
    (reversed, finite)."""
    n, f = float(cam.near), float(cam.far)
    if cam.ortho or _is_ortho(cam.proj):
        return np.array([0.0, 0.0, 1.0 / (f - n), f / (f - n)])
    return np.array([0.0, 0.0, 0.0, n])


def render_projection(cam, zero_to_one: bool) -> np.ndarray:
    """The projection the GPU draws with: the camera's lens (its x, y and w rows) with
    reversed depth. zero_to_one: clip z is the window depth (glClipControl); else NDC
    z = 2 window - 1 (GL's default [-1, 1])."""
    p = np.array(cam.proj, np.float64)
    z = window_depth_row(cam)
    p[2] = z if zero_to_one else 2.0 * z - p[3]
    return p


def window_matrix(cam) -> np.ndarray:
    """Camera-relative position -> (x, y, window depth, w) with x, y in [0, 1]: the
    same for both clip conventions. position_from_depth uses its inverse."""
    p = np.array(cam.proj, np.float64)
    s = np.empty((4, 4))
    s[0] = 0.5 * (p[0] + p[3])
    s[1] = 0.5 * (p[1] + p[3])
    s[2] = window_depth_row(cam)
    s[3] = p[3]
    return s @ relative_view(cam)


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
