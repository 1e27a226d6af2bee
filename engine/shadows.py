"""Shadow maps, one light at a time, for lights that cast shadows (`light.shadow`).

Pass (reads -> writes): scene meshes (DrawItems) -> one DEPTH32F atlas per light,
made just before the light is drawn and released after it (a cube at ultra would be
hundreds of MB; only one lives at a time).

Layouts (every map is a set of tiles in one 2D depth texture):
  spot (half angle <= 60 deg)   1 perspective tile looking down the cone.
  point, wide spot, rect, disk  6 cube-face tiles (3 x 2), 90 deg each plus a border
                                of BORDER texels, so a tap chosen by its own direction's
                                major axis (as a hardware cube map does) never filters
                                across a tile edge: the shadow is continuous across faces.
  sun                           N orthographic cascades (1 x N), each fitted to a slice
                                of the view frustum clipped to the bounds of what is
                                drawn this frame (posed skinned meshes included); depth
                                spans the whole scene so off-screen casters still cast.

Stored depth is linear: radial maps write distance / far (shadow.frag), so every
face stores the same quantity and PCSS reads blocker distances directly; ortho
depth is linear already. The lookup (shaders/shadow_lookup.glsl) does the bias
(normal offset + receiver-plane depth + slope-scaled constant), a PCSS blocker
search, and PCF with hardware compares (sampler2DShadow, bilinear).

`draw_caster` is the one place a caster is drawn (skinning extends it)."""
from __future__ import annotations

import math

import numpy as np

from . import skinning
from .camera import frustum, look_at, ortho
from .shaders import program, set_uniform

BORDER = 2                 # cube tiles: texels beyond 90 deg on each side
MAX_CUBE_TILE = 2048       # a cube is 3 x 2 tiles: cap its memory
SPOT_MAX_HALF_ANGLE = 60.0  # wider spots use the cube layout
MIN_RES, MAX_RES = 64, 8192
# Cube faces: (forward, up) in GL's cube-map order +X -X +Y -Y +Z -Z.
CUBE_FACES = [((1, 0, 0), (0, -1, 0)), ((-1, 0, 0), (0, -1, 0)), ((0, 1, 0), (0, 0, 1)),
              ((0, -1, 0), (0, 0, -1)), ((0, 0, 1), (0, -1, 0)), ((0, 0, -1), (0, -1, 0))]


def _view(eye, forward, up):
    """View matrix of a shadow map at `eye` looking along `forward`."""
    eye = np.asarray(eye, float)
    return np.linalg.inv(look_at(eye, eye + np.asarray(forward, float), np.asarray(up, float)))


def resolution(light, opts) -> int:
    res = int(light.shadow_resolution or opts["shadow_size"])
    return int(min(max(res, MIN_RES), MAX_RES))


def draw_caster(frame, draw, view_proj, light, sm):
    """Draws one DrawItem's triangles into the bound depth target with `view_proj`.
    Every caster goes through here: the mesh's own shader variant (skinned meshes
    cast their posed shadow) and the frame's shared geometry buffers."""
    mesh = frame.scene.meshes[draw.mesh_key]
    if not mesh.ranges:
        return
    prog = program(frame.ctx, "shadow.vert", "shadow.frag", skinning.defines(mesh.skin))
    set_uniform(prog, "radial", sm.radial)
    set_uniform(prog, "light_pos", np.asarray(light.position, float))
    set_uniform(prog, "far", sm.far)
    set_uniform(prog, "model", draw.world)
    set_uniform(prog, "view_proj", view_proj)
    frame.bind_skin(prog, draw, mesh)
    first = mesh.ranges[0][1]
    count = sum(r[2] for r in mesh.ranges)
    frame.mesh_vao(prog, mesh).render(frame.ctx.TRIANGLES, vertices=count, first=first)
    frame.stats["shadow_draws"] += 1


class ShadowMap:
    """A rendered atlas and what the lookup needs (see set_uniforms)."""

    def __init__(self, radial, tiles, mats, rects, texel, far=1.0, splits=(), ranges=(),
                 size=0.0):
        self.radial, self.tiles = radial, tiles
        self.mats, self.rects = mats, rects
        self.texel = texel          # radial: world texel per unit distance; ortho: per cascade
        self.far = far
        self.splits, self.ranges = list(splits), list(ranges)
        self.size = size            # radial: light radius; ortho: tan(half angle)
        self.texture = self.cmp = self.raw = None

    def set_uniforms(self, prog, opts, cmp_unit=6, raw_unit=7):
        self.cmp.use(cmp_unit)
        self.raw.use(raw_unit)
        set_uniform(prog, "shadow_cmp", cmp_unit)
        set_uniform(prog, "shadow_raw", raw_unit)
        set_uniform(prog, "shadow_radial", self.radial)
        set_uniform(prog, "shadow_tiles", self.tiles)
        mats = np.zeros((6, 4, 4), "f4")
        for i, m in enumerate(self.mats):
            mats[i] = m.T
        if "shadow_mats" in prog:
            prog["shadow_mats"].write(mats.tobytes())
        rects = np.zeros((6, 4), "f4")
        rects[:len(self.rects)] = self.rects
        set_uniform(prog, "shadow_rects", rects)
        set_uniform(prog, "shadow_far", self.far)
        set_uniform(prog, "shadow_size", self.size)
        if self.radial:
            set_uniform(prog, "shadow_texel", float(self.texel))
        else:
            pad = lambda v, fill: tuple((list(v) + [fill] * 4)[:4])  # noqa: E731
            set_uniform(prog, "shadow_splits", pad(self.splits, -1.0))
            set_uniform(prog, "shadow_ranges", pad(self.ranges, 1.0))
            set_uniform(prog, "shadow_texels", pad(self.texel, 1.0))
        set_uniform(prog, "pcf_taps", int(opts["pcf_taps"]))
        set_uniform(prog, "blocker_taps", int(opts["blocker_taps"]))

    def release(self):
        for obj in (self.cmp, self.raw, self.texture):
            if obj is not None:
                obj.release()


def _bounds_corners(bounds):
    lo, hi = bounds
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (lo[2], hi[2])])


def _scene_far(bounds, origin, fallback):
    """Distance from origin to the farthest corner of the casters' bounds."""
    if bounds is None:
        return fallback
    return float(np.max(np.linalg.norm(_bounds_corners(bounds) - origin, axis=1)))


def plan(frame, light, R):
    """ShadowMap geometry (matrices, tiles) for one light, or None (nothing to shadow)."""
    opts = frame.opts
    res = resolution(light, opts)
    if light.kind == "distant":
        return _plan_sun(frame, light, res)
    pos = np.asarray(light.position, float)
    far = max(min(R, _scene_far(frame.geometry_bounds(), pos, R)) * 1.01, 1e-3)
    near = max(far * 1e-4, 1e-4)
    if light.kind in ("sphere", "spot", "rect", "disk"):
        size = light.radius if light.kind in ("sphere", "spot", "disk") else \
            math.sqrt(light.width * light.height / math.pi)
    if light.kind == "spot" and light.cone_angle <= SPOT_MAX_HALF_ANGLE:
        half = min(math.radians(light.cone_angle) * 1.1 + 0.02, math.radians(80))
        t = math.tan(half) * near
        proj = frustum(-t, t, -t, t, near, far)
        up = light.y_axis if abs(np.dot(light.y_axis, light.axis)) < 0.9 else light.x_axis
        m = proj @ _view(pos, light.axis, up)
        return ShadowMap(True, 1, [m], [(0.0, 0.0, 1.0, 1.0)], 2 * math.tan(half) / res,
                         far=far, size=size), (res, res)
    res = min(res, MAX_CUBE_TILE)
    k = (res + 2 * BORDER) / res          # the tile sees a little beyond 90 deg
    t = near * k
    proj = frustum(-t, t, -t, t, near, far)
    mats, rects = [], []
    for i, (fwd, up) in enumerate(CUBE_FACES):
        mats.append(proj @ _view(pos, fwd, up))
        rects.append(((i % 3) / 3, (i // 3) / 2, 1 / 3, 1 / 2))
    return ShadowMap(True, 6, mats, rects, 2 * k / res, far=far, size=size), (3 * res, 2 * res)


def _plan_sun(frame, light, res):
    cam = frame.scene.camera
    bounds = frame.geometry_bounds()
    if bounds is None:
        return None
    d = light.direction
    up = [0, 0, 1.0] if abs(d[2]) < 0.9 else [0, 1.0, 0]
    corners = _bounds_corners(bounds)
    view = _view(np.zeros(3), d, up)
    lc = (view[:3, :3] @ corners.T).T          # scene bounds in light space
    lo_b, hi_b = lc.min(axis=0), lc.max(axis=0)
    # The visible depth range, clipped to the scene.
    depth = (corners - cam.position) @ cam.forward
    z0 = max(cam.near, float(depth.min()))
    z1 = min(cam.far, float(depth.max()))
    if z1 < z0:
        return None                       # the scene is wholly outside the view
    # A scene flat along the view (a plane seen straight on) still needs a slice.
    pad = 1e-3 * max(z1, 1.0)
    z0, z1 = max(cam.near, z0 - pad), min(cam.far, z1 + pad)
    n = int(frame.opts["cascades"])
    splits = []
    for i in range(1, n + 1):
        f = i / n
        log = z0 * (z1 / z0) ** f
        splits.append(0.75 * log + 0.25 * (z0 + (z1 - z0) * f))
    inv = frame.inv_view_proj
    ndc = np.array([[x, y, z, 1.0] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)])
    w = (inv @ ndc.T).T
    w = w[:, :3] / w[:, 3:4]
    near_c, far_c = w[:4], w[4:]
    dn = (near_c - cam.position) @ cam.forward
    df = (far_c - cam.position) @ cam.forward
    mats, rects, texels, ranges = [], [], [], []
    start = z0
    for i, end in enumerate(splits):
        pts = []
        for z in (start, end):
            t = ((z - dn) / np.maximum(df - dn, 1e-12))[:, None]
            pts.append(near_c + (far_c - near_c) * t)
        pts = np.concatenate(pts)
        pl = (view[:3, :3] @ pts.T).T
        lo = np.maximum(pl.min(axis=0), lo_b)
        hi = np.minimum(pl.max(axis=0), hi_b)
        if np.any(hi[:2] <= lo[:2]):           # slice outside the scene: a dummy tile
            lo, hi = lo_b.copy(), hi_b.copy()
        # A square tile, padded by the PCF footprint so edge taps stay inside.
        ext = max(hi[0] - lo[0], hi[1] - lo[1]) * (1 + 16.0 / res)
        c = (lo + hi) / 2
        znear, zfar = -hi_b[2] - 1e-3, -lo_b[2] + 1e-3   # the whole scene along the light
        proj = ortho(c[0] - ext / 2, c[0] + ext / 2, c[1] - ext / 2, c[1] + ext / 2, znear, zfar)
        mats.append(proj @ view)
        rects.append((i / n, 0.0, 1.0 / n, 1.0))
        texels.append(ext / res)
        ranges.append(zfar - znear)
        start = end
    size = math.tan(math.radians(light.angle) / 2)
    return ShadowMap(False, n, mats, rects, texels, splits=splits, ranges=ranges,
                     size=size), (n * res, res)


def render(frame, light, R):
    """Renders the light's shadow map; returns a ShadowMap or None. Leaves no
    framebuffer bound that the caller relies on: the caller re-binds its own."""
    planned = plan(frame, light, R)
    if planned is None:
        return None
    sm, (tw, th) = planned
    ctx = frame.ctx
    sm.texture = ctx.depth_texture((tw, th))
    sm.texture.compare_func = ""
    sm.texture.filter = (ctx.NEAREST, ctx.NEAREST)
    fbo = ctx.framebuffer(depth_attachment=sm.texture)
    try:
        fbo.use()
        fbo.clear(depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        ctx.disable(ctx.BLEND | ctx.CULL_FACE)   # single-sided planes cast too
        for m, (x, y, sx, sy) in zip(sm.mats, sm.rects):
            fbo.viewport = (round(x * tw), round(y * th), round(sx * tw), round(sy * th))
            fbo.use()
            frame.stats["shadow_passes"] += 1
            for draw in frame.scene.draws:
                draw_caster(frame, draw, m, light, sm)
    finally:
        fbo.release()
        ctx.disable(ctx.DEPTH_TEST)
    # Two views of one texture: hardware compare (bilinear PCF) and raw depth (PCSS).
    sm.cmp = ctx.sampler(texture=sm.texture, filter=(ctx.LINEAR, ctx.LINEAR),
                         compare_func="<=", repeat_x=False, repeat_y=False)
    sm.raw = ctx.sampler(texture=sm.texture, filter=(ctx.NEAREST, ctx.NEAREST),
                         compare_func="", repeat_x=False, repeat_y=False)
    return sm
