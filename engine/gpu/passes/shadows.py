"""The shadow pass: a depth atlas per light that casts shadows (`light.shadow`), kept
by the session and drawn again only when it would change:
  - a point, spot or area light's map when that light changed or its fit to the
    casters' bounds moved, and otherwise only the tiles (cube faces) in which a
    caster within its range changed (its box before or after an edit, a skinned
    caster's posed box);
  - a sun's cascades when their fit to the view (or to the casters) changed, and
    otherwise only the cascades in which a caster changed.
Maps are textures from the session's pool; a light that stops casting gives its back.

Shadow maps share a memory budget (SHADOW_BUDGET_BYTES): lights are given maps in order
of importance (suns first, then by intensity over squared distance to the camera) until
the next map would pass it; the rest are lit without shadows, and the render warns once
with their number. 20,000 shadow-casting lights would otherwise need 500 GB of maps.

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

Maps are fitted in light-relative space: a radial map's matrices are relative to the
light's position, a sun's to an anchor (the eye, which its cascades follow), both
carried in double precision, and casters are drawn relative to that anchor (their
translations are double-float pairs, shaders/origin.glsl). So a map's precision
depends on the scene's size about the light, not on its distance to the world origin.
The lookup matrices carry camera-relative receivers (lib.glsl) to the map's uv and
depth in [0, 1], whatever the GL's clip convention (engine/gpu/depth.py).

Stored depth is linear, in a 32-bit float: radial maps write distance / far
(shadow.frag), so every face stores the same quantity and PCSS reads blocker
distances directly; ortho depth is linear already. The lookup (shaders/shadow_lookup.glsl) does the bias
(normal offset + receiver-plane depth + slope-scaled constant), a PCSS blocker
search, and PCF with hardware compares (sampler2DShadow, bilinear).

reads: skinned (posed casters), view   writes: shadow_maps (light path -> ShadowMap)"""
from __future__ import annotations

import math

import numpy as np

from ....core.lights import DISK, POINT, SPOT, SUN
from ....core.transforms import aabb_corners, frustum, look_at, ortho
from ...view import boxes_outside, frustum_planes, relative_view, translate
from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from .gbuffer import set_material
from .view import set_origin

BORDER = 2                 # cube tiles: texels beyond 90 deg on each side
MAX_CUBE_TILE = 2048       # a cube is 3 x 2 tiles: cap its memory
SPOT_MAX_HALF_ANGLE = 60.0  # wider spots use the cube layout
MIN_RES, MAX_RES = 64, 8192
# Every shadow map of a frame together (32-bit depth texels): under llvmpipe they are
# host memory, and a render must leave a user's machine room. 1 GiB measured 1.86 GiB
# peak resident at 640x360 (bench/bench_light_scaling.py): half that leaves room for
# larger images and supersampling. Medium's point-light cube is 24 MiB: 21 fit.
SHADOW_BUDGET_BYTES = 512 << 20
BUDGET_WARNING = "shadow maps"     # the scene's warnings key for the budget's line
# Cube faces: (forward, up) in GL's cube-map order +X -X +Y -Y +Z -Z.
CUBE_FACES = [((1, 0, 0), (0, -1, 0)), ((-1, 0, 0), (0, -1, 0)), ((0, 1, 0), (0, 0, 1)),
              ((0, -1, 0), (0, 0, -1)), ((0, 0, 1), (0, -1, 0)), ((0, 0, -1), (0, -1, 0))]
# GL projection (NDC [-1, 1]) -> texture space [0, 1] (the bias matrix of docs/design.md, "Shadow maps").
BIAS = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])
# GL projection -> the same window depth under glClipControl's ZERO_TO_ONE.
ZERO_TO_ONE = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])


def _view(forward, up):
    """View matrix of a shadow map at its anchor (the origin) looking along `forward`:
    a rotation."""
    zero = np.zeros(3)
    return np.linalg.inv(look_at(zero, np.asarray(forward, float), np.asarray(up, float)))


def resolution(light, preset) -> int:
    res = int(light.shadow_resolution or preset.shadow_size)
    return int(min(max(res, MIN_RES), MAX_RES))


class ShadowMap:
    """An atlas's layout and what the lookup needs (see set_uniforms); `texture` and
    its two samplers once rendered."""

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

    def same_layout(self, other) -> bool:
        return other is not None and self.atlas == other.atlas and \
            np.array_equal(self.anchor, other.anchor) and \
            self.radial == other.radial and self.tiles == other.tiles and \
            self.far == other.far and self.size == other.size and \
            all(np.array_equal(a, b) for a, b in zip(self.mats, other.mats)) and \
            self.splits == other.splits and self.ranges == other.ranges and \
            self.texel == other.texel

    def set_uniforms(self, prog, preset, eye):
        """The lookup of camera-relative receivers (the camera at `eye`, world)."""
        self.cmp.use(UNITS["shadow_cmp"])
        self.raw.use(UNITS["shadow_raw"])
        set_uniform(prog, "shadow_radial", self.radial)
        set_uniform(prog, "shadow_tiles", self.tiles)
        mats = np.zeros((6, 4, 4), "f4")
        to_anchor = translate(np.asarray(eye, np.float64) - self.anchor)
        for i, m in enumerate(self.mats):
            mats[i] = (BIAS @ m @ to_anchor).T    # column-major, as GLSL reads a mat4
        set_uniform(prog, "shadow_mats", mats)
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
        set_uniform(prog, "shadow_footprint", self.footprint if self.stochastic else (0.0, 0.0))
        set_uniform(prog, "pcf_taps", int(preset.pcf_taps))
        set_uniform(prog, "blocker_taps", int(preset.blocker_taps))

    def adopt(self, old: "ShadowMap"):
        """Takes over an older map's texture and samplers (same atlas size)."""
        self.texture, self.cmp, self.raw = old.texture, old.cmp, old.raw
        old.texture = old.cmp = old.raw = None


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
        math.sqrt(light.width * light.height / math.pi)
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


def _importance(light, eye) -> float:
    """Which lights get a shadow map first: suns, then the brightest at the camera
    (intensity over squared distance, at least the light's own size)."""
    if light.kind == SUN:
        return math.inf
    d2 = float(np.sum((np.asarray(light.position, np.float64) - eye) ** 2))
    return float(np.max(light.color)) / max(d2, light.radius ** 2, 1e-12)


def _budget_warning(scene, unshadowed, casting):
    scene.warnings[BUDGET_WARNING] = [
        f"{unshadowed} of {casting} shadow-casting lights are lit without shadows: their "
        f"shadow maps would pass the {SHADOW_BUDGET_BYTES >> 20} MiB shadow memory budget"]


def casts(light, R) -> bool:
    """Whether a light gets a map: it casts and has something to light."""
    return light.shadow and (light.kind == SUN or R > 0)


class ShadowPass(Pass):
    name = "shadows"
    reads = ("skinned", "view")
    writes = ("shadow_maps",)

    def __init__(self, ctx, pool, programs, geometry, lights, depth, textures):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.geometry, self.lights = geometry, lights
        self.preset = None         # what self.maps were planned with
        self._kept = {}            # other presets' maps: name -> (maps, see-through)
        self.depth, self.textures = depth, textures
        self.maps = {}             # light path -> ShadowMap, kept across frames
        self._see_through = None   # what the kept maps' see-through casters were drawn with

    def needed(self, frame):
        has_casters = self.geometry.has_casters()
        wanted = has_casters and any(
            casts(light, self.lights.ranges.get(path, 0.0))
            for path, light in frame.scene.lights.items())
        if not wanted:
            self._drop(list(self.maps))
            self._drop_kept()
            frame.scene.warnings.pop(BUDGET_WARNING, None)
        return wanted

    def execute(self, frame, board):
        scene, view = frame.scene, board["view"]
        moved = self.geometry.moved
        see_through = _see_through(scene)
        if frame.preset != self.preset:
            # Each preset keeps its own maps (their sizes and cascades differ), so a
            # view that settles from the interactive preset finds its maps drawn.
            if self.preset is not None:
                self._kept[self.preset.name] = (self.maps, self._see_through)
            self.maps, self._see_through = self._kept.pop(frame.preset.name, ({}, None))
            self.preset = frame.preset
        if frame.changes.lights or moved:
            self._drop_kept()            # they missed what this frame's maps will see
        if see_through != self._see_through:
            self._drop(list(self.maps))  # a cut-out or blended material changed: all again
            self._see_through = see_through
        for path in [p for p in self.maps if p not in scene.lights or p in frame.changes.lights]:
            self._drop([path])           # stale: drawn again below if it still casts
        out, used, casting = {}, 0, []
        for path, light in scene.lights.items():
            if casts(light, self.lights.ranges[path]):
                casting.append(path)
            else:
                self._drop([path])
        casting.sort(key=lambda p: -_importance(scene.lights[p], view.origin))
        for n, path in enumerate(casting):
            light, R = scene.lights[path], self.lights.ranges[path]
            old = self.maps.get(path)
            bounds = _key(view.bounds)
            if old is not None and old.inputs == (light, bounds) and light.kind != SUN:
                sm = old                   # same light, same casters' bounds: same layout
            else:
                sm = plan(light, R, self.preset, view.bounds, view)
                if sm is None:
                    self._drop([path])
                    continue
                sm.inputs = (light, bounds)
                if sm.same_layout(old):
                    old.inputs, sm = sm.inputs, old
            used += sm.atlas[0] * sm.atlas[1] * 4
            if used > SHADOW_BUDGET_BYTES:
                self._drop(casting[n:])      # these, and every less important one
                _budget_warning(scene, len(casting) - n, len(casting))
                break
            tiles = _stale_tiles(sm, light, R, moved) if sm is old else range(sm.tiles)
            if not tiles:
                out[path] = old
                continue
            self._render(frame, sm, old, light, tiles)
            self.maps[path] = out[path] = sm
            frame.count("shadow_maps_rendered")
            frame.count("shadow_passes", len(tiles))
        else:
            scene.warnings.pop(BUDGET_WARNING, None)
        frame.count("shadow_maps", len(out))
        frame.count("unshadowed_lights", len(casting) - len(out))
        # A screen pixel's width per unit of view depth (perspective) or in all (ortho).
        pixel = 2.0 / (abs(float(view.camera.proj[1][1])) * frame.size[1])
        for sm in out.values():
            sm.footprint = (0.0, pixel) if view.camera.ortho else (pixel, 0.0)
        board["shadow_maps"] = out

    def _render(self, frame, sm, old, light, tiles):
        """Draws the given tiles of the map (all of a new one), each cleared and
        scissored to its own rectangle."""
        if sm is old:
            pass                           # drawn again into its own texture
        elif old is not None and old.atlas == sm.atlas:
            sm.adopt(old)
        else:
            if old is not None:
                self._release_map(old)
            ctx = self.ctx
            sm.texture = self.pool.acquire(sm.atlas, "depth")
            # Two views of one texture: hardware compare (bilinear PCF), raw depth (PCSS).
            sm.cmp = ctx.sampler(texture=sm.texture, filter=(ctx.LINEAR, ctx.LINEAR),
                                 compare_func="<=", repeat_x=False, repeat_y=False)
            sm.raw = ctx.sampler(texture=sm.texture, filter=(ctx.NEAREST, ctx.NEAREST),
                                 compare_func="", repeat_x=False, repeat_y=False)
        ctx = self.ctx
        tw, th = sm.atlas
        fbo = self.pool.framebuffer(depth=sm.texture)
        ctx.disable(ctx.BLEND | ctx.CULL_FACE)   # single-sided planes cast too
        prog = self.programs.get("shadow.vert", "shadow.frag", self.geometry.object_defines())
        self.geometry.bind_objects(UNITS["u_objects"])
        set_uniform(prog, "radial", sm.radial)
        set_uniform(prog, "light_pos", np.asarray(light.position, float) - sm.anchor)
        set_uniform(prog, "far", sm.far)
        set_origin(prog, sm.anchor)
        clip = ZERO_TO_ONE if self.depth.zero_to_one else np.eye(4)
        for i in tiles:
            x, y, sx, sy = sm.rects[i]
            rect = (round(x * tw), round(y * th), round(sx * tw), round(sy * th))
            fbo.viewport = rect
            fbo.use()
            fbo.clear(depth=1.0, viewport=rect)
            ctx.scissor = rect
            ctx.enable(ctx.DEPTH_TEST)
            ctx.depth_func = "<"
            set_uniform(prog, "view_proj", clip @ sm.mats[i])
            frame.count("shadow_draws", self.geometry.draw_casters(prog))
            sm.stochastic |= self._draw_see_through(frame, sm, light, clip @ sm.mats[i])
            if self.geometry.points.clouds:
                frame.count("shadow_draws", self._draw_points(sm, light, clip @ sm.mats[i],
                                                              BIAS @ sm.mats[i]))
        ctx.scissor = None
        ctx.disable(ctx.DEPTH_TEST)

    def _draw_see_through(self, frame, sm, light, view_proj):
        """Ranges of cut-out and blended materials, each testing its opacity
        (shadow.frag ALPHA_TEST), one draw per range; returns whether any was blended."""
        blended = False
        for store, name, first, count, oid, n in self.geometry.alpha_casters():
            mat = frame.scene.materials[name]
            prog = self.programs.get("shadow.vert", "shadow.frag", ["ALPHA_TEST"] + (
                ["HAS_OPACITY_MAP"] if "opacity" in mat.maps else []))
            set_uniform(prog, "radial", sm.radial)
            set_uniform(prog, "light_pos", np.asarray(light.position, float) - sm.anchor)
            set_uniform(prog, "far", sm.far)
            set_origin(prog, sm.anchor)
            set_uniform(prog, "view_proj", view_proj)
            set_material(prog, mat, self.textures,
                         mat.opacity_threshold if mat.alpha == "clip" else 0.0)
            prog["u_object"].value = int(oid)
            store.vao(prog).render(self.ctx.TRIANGLES, vertices=int(count), first=int(first),
                                   instances=int(n))
            frame.count("shadow_draws")
            blended |= mat.alpha == "blend"
        return blended

    def _draw_points(self, sm, light, view_proj, window) -> int:
        """Point clouds into a tile: spheres facing the light (radial maps) or across
        the sun's direction, writing the same depth as meshes do."""
        def setup(prog, cloud):
            set_uniform(prog, "view_proj", view_proj)
            set_uniform(prog, "u_window", window)
            set_uniform(prog, "u_far", 1e30)
            set_uniform(prog, "radial", sm.radial)
            set_uniform(prog, "far", sm.far)
            set_uniform(prog, "u_face_axis", not sm.radial)
            set_uniform(prog, "u_axis", np.asarray(light.direction, np.float64))
            set_origin(prog, sm.anchor)
        draws, _ = self.geometry.points.draw(self.programs, "shadow", setup)
        return draws

    def _drop(self, paths):
        for path in paths:
            sm = self.maps.pop(path, None)
            if sm is not None:
                self._release_map(sm)

    def _release_map(self, sm):
        if sm.texture is not None:
            sm.cmp.release()
            sm.raw.release()
            self.pool.release(sm.texture)
            sm.texture = sm.cmp = sm.raw = None

    def _drop_kept(self):
        for maps, _ in self._kept.values():
            for sm in maps.values():
                self._release_map(sm)
        self._kept = {}

    def release(self):
        self._drop(list(self.maps))
        self._drop_kept()


def _see_through(scene) -> tuple:
    """What the see-through casters' shadows depend on: their materials' opacity."""
    return tuple(sorted((name, m.alpha, m.opacity, m.opacity_threshold, m.maps.get("opacity"))
                        for name, m in scene.materials.items() if m.alpha != "opaque"))


def _key(bounds):
    return None if bounds is None else (tuple(bounds[0]), tuple(bounds[1]))


def _stale_tiles(sm, light, R, moved) -> list:
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
    lo, hi = lo - sm.anchor, hi - sm.anchor        # the maps' matrices are anchor-relative
    return [i for i, m in enumerate(sm.mats)
            if not np.all(boxes_outside(frustum_planes(m), lo, hi))]
