"""Where each light's shadow map goes, in numpy and without GL: the layout of its atlas
(a spot's one tile, a point or area light's six cube faces, a sun's cascades fitted
to the view), which lights get one first, and which tiles of a kept map an edit makes
stale. The shadow pass (engine/gpu/passes/shadows.py) draws what this plans; the
layouts' reasons are in its module note."""
from __future__ import annotations

import math

import numpy as np

from ..core.lights import DISK, POINT, SPOT, SUN
from ..core.transforms import aabb_corners, frustum, look_at, ortho
from .lighting import light_area
from .view import boxes_outside, frustum_planes, relative_view

BORDER = 2                 # cube tiles: texels beyond 90 deg on each side
MAX_CUBE_TILE = 2048       # a cube is 3 x 2 tiles: cap its memory
SPOT_MAX_HALF_ANGLE = 60.0  # wider spots use the cube layout
MIN_RES, MAX_RES = 64, 8192
# Cube faces: (forward, up) in GL's cube-map order +X -X +Y -Y +Z -Z.
CUBE_FACES = [((1, 0, 0), (0, -1, 0)), ((-1, 0, 0), (0, -1, 0)), ((0, 1, 0), (0, 0, 1)),
              ((0, -1, 0), (0, 0, -1)), ((0, 0, 1), (0, -1, 0)), ((0, 0, -1), (0, -1, 0))]


def _view(forward, up):
    """View matrix of a shadow map at its anchor (the origin) looking along `forward`:
    a rotation, so the transpose of the camera's world matrix. (np.linalg.inv took up
    to 2.7 ms a call here on llvmpipe: LAPACK's threads wait on the rasteriser's.)"""
    zero = np.zeros(3)
    return look_at(zero, np.asarray(forward, float), np.asarray(up, float)).T.copy()


def resolution(light, preset) -> int:
    res = int(light.shadow_resolution or preset.shadow_size)
    return int(min(max(res, MIN_RES), MAX_RES))


class ShadowMap:
    """An atlas's layout and what the lookup needs; `texture` and its two samplers
    (comparing, raw), and `tint` where glass casts into it, once the shadow pass has
    drawn it (engine/gpu/passes/shadows.py, which also sets the lookup's uniforms)."""

    def __init__(self, radial, tiles, mats, rects, texel, far=1.0, splits=(), ranges=(),
                 size=0.0, atlas=(0, 0), anchor=(0.0, 0.0, 0.0)):
        self.radial, self.tiles = radial, tiles
        self.mats, self.rects = mats, rects   # GL projections of anchor-relative positions
        self.anchor = np.asarray(anchor, np.float64)  # world, what positions are relative to
        self.texel = texel          # radial: world texel per unit distance; ortho: per cascade
        self.far = far
        self.splits, self.ranges = list(splits), list(ranges)
        self.size = size            # radial: light radius; ortho: tan(half angle)
        self.atlas = atlas          # texture size
        self.inputs = None          # (light record, casters' bounds) it was planned for
        self.stochastic = False     # drawn with blended casters (shadow.frag)
        self.footprint = (0.0, 0.0)  # their filter's least width: a screen pixel's (lookup)
        self.texture = self.cmp = self.raw = None
        self.tint = None            # glass casters' colour and nearest depth (rgba16f)
        self.exit = self.exit_raw = None  # area lights: the casters' far sides (shadow_exits)

    def tile_pixels(self, tile: int) -> tuple:
        """Tile `tile`'s rectangle in the atlas, pixels (x, y, width, height)."""
        (tw, th), (x, y, sx, sy) = self.atlas, self.rects[tile]
        return (round(x * tw), round(y * th), round(sx * tw), round(sy * th))

    def same_layout(self, other) -> bool:
        return other is not None and self.atlas == other.atlas and \
            np.array_equal(self.anchor, other.anchor) and \
            self.radial == other.radial and self.tiles == other.tiles and \
            self.far == other.far and self.size == other.size and \
            all(np.array_equal(a, b) for a, b in zip(self.mats, other.mats)) and \
            self.splits == other.splits and self.ranges == other.ranges and \
            self.texel == other.texel

    def adopt(self, old: "ShadowMap"):
        """Takes over an older map's texture and samplers (same atlas size)."""
        self.texture, self.cmp, self.raw, self.tint = old.texture, old.cmp, old.raw, old.tint
        self.exit, self.exit_raw = old.exit, old.exit_raw
        old.texture = old.cmp = old.raw = old.tint = old.exit = old.exit_raw = None


def _scene_far(bounds, origin, fallback):
    """Distance from origin to the farthest corner of the casters' bounds."""
    if bounds is None:
        return fallback
    return float(np.max(np.linalg.norm(aabb_corners(*bounds) - origin, axis=1)))


def plan(light, R, preset, bounds, view):
    """A ShadowMap layout (matrices, tiles) for one light, or None (nothing to shadow).
    bounds: the world box of what is drawn this frame."""
    res = resolution(light, preset)
    if light.kind == SUN:
        return _plan_sun(light, res, preset, bounds, view)
    pos = np.asarray(light.position, float)
    far = min(R, _scene_far(bounds, pos, R)) * 1.01
    if not far > 0:
        return None
    near = far * 1e-4
    size = light.radius if light.kind in (POINT, SPOT, DISK) else \
        math.sqrt(light_area(light) / math.pi)
    if light.kind == SPOT and light.cone_angle <= SPOT_MAX_HALF_ANGLE:
        half = min(math.radians(light.cone_angle) * 1.1 + 0.02, math.radians(80))
        t = math.tan(half) * near
        proj = frustum(-t, t, -t, t, near, far)
        up = light.y_axis if abs(np.dot(light.y_axis, light.axis)) < 0.9 else light.x_axis
        m = proj @ _view(light.axis, up)
        return ShadowMap(True, 1, [m], [(0.0, 0.0, 1.0, 1.0)], 2 * math.tan(half) / res,
                         far=far, size=size, atlas=(res, res), anchor=pos)
    res = min(res, MAX_CUBE_TILE)
    k = (res + 2 * BORDER) / res          # the tile sees a little beyond 90 deg
    t = near * k
    proj = frustum(-t, t, -t, t, near, far)
    mats, rects = [], []
    for i, (fwd, up) in enumerate(CUBE_FACES):
        mats.append(proj @ _view(fwd, up))
        rects.append(((i % 3) / 3, (i // 3) / 2, 1 / 3, 1 / 2))
    return ShadowMap(True, 6, mats, rects, 2 * k / res, far=far, size=size,
                     atlas=(3 * res, 2 * res), anchor=pos)


def _plan_sun(light, res, preset, bounds, view):
    """Cascades fitted to the view, relative to the eye (the anchor): every length is
    taken relative to the scene's own size, so a scene and its scaled copy get the
    same maps (a hard case)."""
    cam = view.camera
    if bounds is None:
        return None
    anchor = np.asarray(view.origin, np.float64)
    d = light.direction
    up = [0, 0, 1.0] if abs(d[2]) < 0.9 else [0, 1.0, 0]
    corners = aabb_corners(*bounds) - anchor
    lview = _view(d, up)
    lc = (lview[:3, :3] @ corners.T).T         # scene bounds in light space
    lo_b, hi_b = lc.min(axis=0), lc.max(axis=0)
    # The visible depth range, clipped to the scene.
    depth = corners @ cam.forward
    z0 = max(cam.near, float(depth.min()))
    z1 = min(cam.far, float(depth.max()))
    if z1 < z0:
        return None                       # the scene is wholly outside the view
    # A scene flat along the view (a plane seen straight on) still needs a slice.
    pad = 1e-3 * z1
    z0, z1 = max(cam.near, z0 - pad), min(cam.far, z1 + pad)
    n = int(preset.cascades)
    splits = []
    for i in range(1, n + 1):
        f = i / n
        log = z0 * (z1 / z0) ** f
        splits.append(0.75 * log + 0.25 * (z0 + (z1 - z0) * f))
    # The view frustum's corners (camera-relative), with the camera's finite far plane.
    inv = np.linalg.inv(np.asarray(cam.proj, np.float64) @ relative_view(cam))
    ndc = np.array([[x, y, z, 1.0] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)])
    w = (inv @ ndc.T).T
    w = w[:, :3] / w[:, 3:4]
    near_c, far_c = w[:4], w[4:]
    dn = near_c @ cam.forward
    df = far_c @ cam.forward
    # Casters right at the scene's bounds along the light stay inside the depth range.
    span = float(np.linalg.norm(hi_b - lo_b))
    zpad = 1e-4 * span if span > 0 else 1.0
    znear, zfar = -hi_b[2] - zpad, -lo_b[2] + zpad   # the whole scene along the light
    mats, rects, texels, ranges = [], [], [], []
    start = z0
    for i, end in enumerate(splits):
        pts = []
        for z in (start, end):
            t = ((z - dn) / (df - dn))[:, None]
            pts.append(near_c + (far_c - near_c) * t)
        pts = np.concatenate(pts)
        pl = (lview[:3, :3] @ pts.T).T
        lo = np.maximum(pl.min(axis=0), lo_b)
        hi = np.minimum(pl.max(axis=0), hi_b)
        if np.any(hi[:2] <= lo[:2]):           # slice outside the scene: a dummy tile
            lo, hi = lo_b.copy(), hi_b.copy()
        # A square tile, padded by the PCF footprint so edge taps stay inside.
        ext = max(hi[0] - lo[0], hi[1] - lo[1]) * (1 + 16.0 / res)
        if not ext > 0:
            ext = zpad
        c = (lo + hi) / 2
        proj = ortho(c[0] - ext / 2, c[0] + ext / 2, c[1] - ext / 2, c[1] + ext / 2, znear, zfar)
        mats.append(proj @ lview)
        rects.append((i / n, 0.0, 1.0 / n, 1.0))
        texels.append(ext / res)
        ranges.append(zfar - znear)
        start = end
    size = math.tan(math.radians(light.angle) / 2)
    return ShadowMap(False, n, mats, rects, texels, splits=splits, ranges=ranges,
                     size=size, atlas=(n * res, res), anchor=anchor)


def importance(light, eye) -> float:
    """Which lights get a shadow map first: suns, then the brightest at the camera
    (intensity over squared distance, at least the light's own size)."""
    if light.kind == SUN:
        return math.inf
    d2 = float(np.sum((np.asarray(light.position, np.float64) - eye) ** 2))
    return float(np.max(light.color)) / max(d2, light.radius ** 2, 1e-12)


def casts(light, R) -> bool:
    """Whether a light gets a map: it casts and has something to light."""
    return light.shadow and (light.kind == SUN or R > 0)


def stale_tiles(sm, light, R, moved) -> list:
    """The tiles of a kept map that a changed box (before or after the change) falls
    in: within the light's reach (a sun reaches all) and inside the tile's frustum."""
    if not moved:
        return []
    lo = np.array([b[0] for b in moved])
    hi = np.array([b[1] for b in moved])
    if light.kind != SUN:
        p = np.asarray(light.position, float)
        near = np.sum((np.clip(p, lo, hi) - p) ** 2, axis=1) <= R * R
        lo, hi = lo[near], hi[near]
        if not len(lo):
            return []
    return [i for i in range(len(sm.mats)) if tile_sees(sm, i, lo, hi).any()]


def tile_sees(sm, i, lo, hi) -> np.ndarray:
    """(n,) bool: which world boxes (n, 3) meet tile i's frustum. A caster outside it
    is clipped whole there, so it need not be drawn into the tile."""
    lo, hi = lo - sm.anchor, hi - sm.anchor        # the maps' matrices are anchor-relative
    return ~boxes_outside(frustum_planes(sm.mats[i]), lo, hi)
