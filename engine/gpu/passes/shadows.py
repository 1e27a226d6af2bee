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

reads: skinned (posed casters), tessellated (optional), view   writes: shadow_maps (light path -> ShadowMap)"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ....core.lights import SUN
from ...shadow_plan import importance, plan, stale_tiles, tile_sees
from ...view import translate
from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from .gbuffer import filter_defines, set_material
from .shadow_exits import give_exits, release_exits, start_tile
from .view import set_origin

# Every shadow map of a frame together (32-bit depth texels): under llvmpipe they are
# host memory, and a render must leave a user's machine room. 1 GiB measured 1.86 GiB
# peak resident at 640x360 (bench/bench_light_scaling.py): half that leaves room for
# larger images and supersampling. Medium's point-light cube is 24 MiB: 21 fit.
SHADOW_BUDGET_BYTES = 512 << 20
BUDGET_WARNING = "shadow maps"     # the scene's warnings key for the budget's line
# GL projection (NDC [-1, 1]) -> texture space [0, 1] (the bias matrix of docs/design.md, "Shadow maps").
BIAS = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])
# GL projection -> the same window depth under glClipControl's ZERO_TO_ONE.
ZERO_TO_ONE = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])


def _budget_warning(scene, unshadowed, casting):
    scene.warnings[BUDGET_WARNING] = [
        f"{unshadowed} of {casting} shadow-casting lights are lit without shadows: their "
        f"shadow maps would pass the {SHADOW_BUDGET_BYTES >> 20} MiB shadow memory budget"]


def _set_light(prog, sm, light, skip=-1):
    """What every caster draw into map `sm` needs of its light: the map's kind, the
    light relative to the map's anchor, the depth scale, the anchor as origin, and the
    object that casts nothing into it (an emissive mesh's own: `skip`, -1 for none)."""
    set_uniform(prog, "skip_object", int(skip))
    set_uniform(prog, "radial", sm.radial)
    set_uniform(prog, "light_pos", np.asarray(light.position, float) - sm.anchor)
    set_uniform(prog, "far", sm.far)
    set_origin(prog, sm.anchor)


CONTACT_RAYS = "CONTACT_RAYS"     # shaders/shadow_lookup.glsl
CONTACT_SEE_THROUGH = "CONTACT_SEE_THROUGH"
OPAQUE_BINDING = 9                # shaders/shadow_lookup.glsl ContactOpaque


class ContactRays:
    """The rays that close the shadow maps' contact leaks (shaders/shadow_lookup.glsl
    CONTACT_RAYS), shared by the light passes of both forms. Only in a frame that
    bounces light: the irradiance field is on the board, so the scene's tracer is built
    (a frame lit directly stays as it was); only for suns, whose maps leak at a sunlit
    room's seams. A point or spot light's program with the walk beside its sphere's
    polygon integral took llvmpipe minutes to compile at its first draw (the demo), and
    an area light's taps march the map along each ray to the light instead.
    A ray counts only opaque surfaces: cut-outs, blended surfaces and glass cast
    through their maps' tested opacity, as before: where a scene has them, a flag per
    tracer material in one small buffer, uploaded when the flags change."""

    def __init__(self, uploads, tracer):
        self.uploads = uploads
        self.tracer = tracer          # scene -> Raytracer (Renderer.tracer); None: no compute
        self._flags = None
        self._buffer = None

    def defines(self, frame, board, light) -> list:
        """[CONTACT_RAYS] (and CONTACT_SEE_THROUGH where some traced material is not
        opaque, with its flags bound) with the tracer bound, for `light` this frame;
        else []."""
        if self.tracer is None or "field" not in board or light.kind != SUN:
            return []
        tracer = self.tracer(frame.scene)
        tracer.bind()
        materials = frame.scene.materials
        flags = np.array([name not in materials or materials[name].alpha == "opaque"
                          for name in tracer.materials] or [True], np.int32)
        if flags.all():
            return [CONTACT_RAYS]       # every hit counts: the cheaper any-hit walk
        if self._flags is None or not np.array_equal(flags, self._flags):
            self.release()
            self._flags, self._buffer = flags, self.uploads.buffer(flags, kind="lights")
        self._buffer.bind_to_storage_buffer(OPAQUE_BINDING)
        return [CONTACT_RAYS, CONTACT_SEE_THROUGH]

    def release(self):
        if self._buffer is not None:
            self._buffer.release()
        self._flags = self._buffer = None


def set_shadow_uniforms(prog, sm, preset, eye):
    """The lookup of map `sm` for camera-relative receivers (the camera at `eye`,
    world)."""
    sm.cmp.use(UNITS["shadow_cmp"])
    sm.raw.use(UNITS["shadow_raw"])
    set_uniform(prog, "shadow_radial", sm.radial)
    set_uniform(prog, "shadow_tiles", sm.tiles)
    mats = np.zeros((6, 4, 4), "f4")
    to_anchor = translate(np.asarray(eye, np.float64) - sm.anchor)
    for i, m in enumerate(sm.mats):
        mats[i] = (BIAS @ m @ to_anchor).T    # column-major, as GLSL reads a mat4
    set_uniform(prog, "shadow_mats", mats)
    rects = np.zeros((6, 4), "f4")
    rects[:len(sm.rects)] = sm.rects
    set_uniform(prog, "shadow_rects", rects)
    set_uniform(prog, "shadow_far", sm.far)
    set_uniform(prog, "shadow_size", sm.size)
    if sm.radial:
        set_uniform(prog, "shadow_texel", float(sm.texel))
    else:
        pad = lambda v, fill: tuple((list(v) + [fill] * 4)[:4])  # noqa: E731
        set_uniform(prog, "shadow_splits", pad(sm.splits, -1.0))
        set_uniform(prog, "shadow_ranges", pad(sm.ranges, 1.0))
        set_uniform(prog, "shadow_texels", pad(sm.texel, 1.0))
    set_uniform(prog, "shadow_footprint", sm.footprint if sm.stochastic else (0.0, 0.0))
    set_uniform(prog, "shadow_exits", sm.exit is not None)
    if sm.exit is not None:
        sm.exit_raw.use(UNITS["shadow_exit"])
    set_uniform(prog, "shadow_tinted", sm.tint is not None)
    if sm.tint is not None:
        sm.tint.use(UNITS["shadow_tint"])
    set_uniform(prog, "pcf_taps", int(preset.pcf_taps))
    set_uniform(prog, "blocker_taps", int(preset.blocker_taps))
    set_uniform(prog, "contact_eye", np.asarray(eye, np.float64))   # CONTACT_RAYS


class ShadowPass(Pass):
    name = "shadows"
    reads = ("skinned", "view")
    optional = ("tessellated",)
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
        wanted = has_casters and bool(self.lights.casting)
        if not wanted:
            self._drop(list(self.maps))
            self._drop_kept()
            frame.scene.warnings.pop(BUDGET_WARNING, None)
        return wanted

    def execute(self, frame, board):
        scene, view = frame.scene, board["view"]
        moved = self.geometry.moved
        see_through = _see_through(scene, frame.glass_refracts)
        tinted = frame.glass_refracts and any(
            frame.scene.materials[c[1]].alpha == "glass"
            for c in self.geometry.commands.alpha_casters())
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
        out, drawn, used = {}, {}, 0
        casting = list(self.lights.casting)       # worked out once per light change
        kept = set(casting)
        # A light that no longer casts, or changed (stale: drawn again below).
        self._drop([p for p in self.maps if p not in kept or p in frame.changes.lights])
        casting.sort(key=lambda p: -importance(scene.lights[p], view.origin))
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
            used += sm.atlas[0] * sm.atlas[1] * (4 + 8 * tinted)
            if used > SHADOW_BUDGET_BYTES:
                self._drop(casting[n:])      # these, and every less important one
                _budget_warning(scene, len(casting) - n, len(casting))
                break
            tiles = stale_tiles(sm, light, R, moved) if sm is old else range(sm.tiles)
            if not tiles:
                out[path] = old
                continue
            self._render(frame, sm, old, light, tiles, tinted, view.boxes)
            self.maps[path] = out[path] = sm
            drawn[path] = tiles
            frame.count("shadow_maps_rendered")
            frame.count("shadow_passes", len(tiles))
        else:
            scene.warnings.pop(BUDGET_WARNING, None)
        frame.count("shadow_draws", give_exits(
            self.ctx, self.pool, self.programs, self.geometry,
            {p: (scene.lights[p], sm) for p, sm in out.items()}, drawn,
            SHADOW_BUDGET_BYTES - used, self._clip(),
            lambda prog, light, sm: _set_light(prog, sm, light, self._emitter_object(light)),
            view.boxes))
        frame.count("shadow_maps", len(out))
        frame.count("unshadowed_lights", len(casting) - len(out))
        # A screen pixel's width per unit of view depth (perspective) or in all (ortho).
        pixel = 2.0 / (abs(float(view.camera.proj[1][1])) * frame.size[1])
        for sm in out.values():
            sm.footprint = (0.0, pixel) if view.camera.ortho else (pixel, 0.0)
        board["shadow_maps"] = out

    def _render(self, frame, sm, old, light, tiles, tinted, boxes):
        """Draws the given tiles of the map (all of a new one), each cleared and
        scissored to its own rectangle, with the casters whose boxes (the view's
        world_boxes) meet the tile; `tinted`: the glass casters' colour too."""
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
        fbo = self.pool.framebuffer(depth=sm.texture)
        ctx.disable(ctx.BLEND | ctx.CULL_FACE)   # single-sided planes cast too
        prog = self.programs.get("shadow.vert", "shadow.frag",
                                 self.geometry.commands.object_defines())
        self.geometry.bind_objects(UNITS["u_objects"])
        skip = self._emitter_object(light)
        _set_light(prog, sm, light, skip)
        clip = self._clip()
        for i in tiles:
            rect = sm.tile_pixels(i)
            start_tile(ctx, fbo, rect)
            set_uniform(prog, "view_proj", clip @ sm.mats[i])
            seen = None if boxes is None else tile_sees(sm, i, boxes[1], boxes[2])
            frame.count("shadow_draws", self.geometry.commands.draw_casters(prog, seen))
            sm.stochastic |= self._draw_see_through(frame, sm, light, clip @ sm.mats[i], skip)
            if self.geometry.points.clouds:
                frame.count("shadow_draws", self._draw_points(sm, light, clip @ sm.mats[i],
                                                              BIAS @ sm.mats[i]))
            if tinted:
                self._draw_tint(frame, sm, light, clip @ sm.mats[i], skip, rect)
        ctx.scissor = None
        ctx.disable(ctx.DEPTH_TEST)

    def _clip(self):
        """GL's projection to this context's clip convention (engine/gpu/depth.py)."""
        return ZERO_TO_ONE if self.depth.zero_to_one else np.eye(4)

    def _emitter_object(self, light) -> int:
        """The object id of the mesh an emissive polygon light comes from (it casts
        nothing into its own light's map), or -1."""
        d = self.geometry.draws.get(light.emitter[0]) if light.emitter else None
        return d.oid + light.emitter[1] if d is not None else -1

    def _draw_see_through(self, frame, sm, light, view_proj, skip=-1):
        """Ranges of cut-out and blended materials, each testing its opacity
        (shadow.frag ALPHA_TEST), one draw per range; returns whether any was blended."""
        blended = False
        refract = frame.glass_refracts
        for store, name, first, count, oid, n in self.geometry.commands.alpha_casters():
            mat = glass_caster(frame.scene.materials[name], refract)
            opacity = mat.maps.get("opacity")
            prog = self.programs.get("shadow.vert", "shadow.frag", ["ALPHA_TEST"] + (
                ["HAS_OPACITY_MAP", *filter_defines([opacity])] if opacity else []))
            _set_light(prog, sm, light, skip)
            set_uniform(prog, "view_proj", view_proj)
            set_material(prog, mat, self.textures,
                         mat.opacity_threshold if mat.alpha == "clip" else 0.0)
            prog["u_object"].value = int(oid)
            store.vao(prog).render(self.ctx.TRIANGLES, vertices=int(count), first=int(first),
                                   instances=int(n))
            frame.count("shadow_draws")
            blended |= mat.alpha == "blend" or mat.opacity < 1.0
        return blended

    def _draw_tint(self, frame, sm, light, view_proj, skip, rect):
        """The glass casters' colour into the tile (shadow.frag TINT): each face
        multiplies its tint (blended DST_COLOR x the tint), the alpha keeps the nearest
        glass's depth (MIN); cleared to white at the far depth. No depth test: glass
        behind an opaque caster tints only receivers that caster shadows."""
        ctx = self.ctx
        if sm.tint is None:
            sm.tint = self.pool.acquire(sm.atlas, "rgba16f")
        fbo = self.pool.framebuffer([sm.tint])
        fbo.viewport = rect
        fbo.use()
        fbo.clear(1.0, 1.0, 1.0, 1.0, viewport=rect)
        ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.DST_COLOR, ctx.ZERO, ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD, ctx.MIN
        prog = self.programs.get("shadow.vert", "shadow.frag", ["TINT"])
        for store, name, first, count, oid, n in self.geometry.commands.alpha_casters():
            mat = frame.scene.materials[name]
            if mat.alpha != "glass":
                continue
            _set_light(prog, sm, light, skip)
            set_uniform(prog, "view_proj", view_proj)
            set_uniform(prog, "u_tint", tuple(float(min(max(c, 0.0), 1.0)) for c in mat.diffuse))
            prog["u_object"].value = int(oid)
            store.vao(prog).render(ctx.TRIANGLES, vertices=int(count), first=int(first),
                                   instances=int(n))
            frame.count("shadow_draws")
        ctx.blend_equation = ctx.FUNC_ADD
        ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
        ctx.disable(ctx.BLEND)

    def _draw_points(self, sm, light, view_proj, window) -> int:
        """Point clouds into a tile: spheres facing the light (radial maps) or across
        the sun's direction, writing the same depth as meshes do."""
        def setup(prog, cloud):
            set_uniform(prog, "view_proj", view_proj)
            set_uniform(prog, "u_window", window)
            set_uniform(prog, "u_far", 1e30)
            _set_light(prog, sm, light)
            set_uniform(prog, "u_face_axis", not sm.radial)
            set_uniform(prog, "u_axis", np.asarray(light.direction, np.float64))
        draws, _ = self.geometry.points.draw(self.programs, "shadow", setup)
        return draws

    def _drop(self, paths):
        for path in paths:
            sm = self.maps.pop(path, None)
            if sm is not None:
                self._release_map(sm)

    def _release_map(self, sm):
        release_exits(self.pool, sm)
        if sm.tint is not None:
            self.pool.release(sm.tint)
            sm.tint = None
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


def glass_caster(mat, refract: bool):
    """A glass material as a shadow caster: blended, of opacity 1 - what a flat pane
    of it lets through at normal incidence, transmission x (1 - F0)^2 (stochastic,
    grey; its colour is the tint map's, _draw_tint); opaque without bounces, as
    Cycles' shadow rays stop at glass. Other materials as they are."""
    if mat.alpha != "glass" or not refract:
        return mat
    f0 = ((mat.ior - 1.0) / (mat.ior + 1.0)) ** 2
    return replace(mat, opacity=1.0 - mat.transmission * (1.0 - f0) ** 2)


def _see_through(scene, refract: bool) -> tuple:
    """What the see-through casters' shadows depend on: their materials' opacity (a
    glass one's, with or without bounces)."""
    return tuple(sorted((name, m.alpha, m.opacity, m.opacity_threshold, m.maps.get("opacity"),
                         glass_caster(m, refract).opacity, tuple(m.diffuse))
                        for name, m in scene.materials.items() if m.alpha != "opaque"))


def _key(bounds):
    return None if bounds is None else (tuple(bounds[0]), tuple(bounds[1]))


