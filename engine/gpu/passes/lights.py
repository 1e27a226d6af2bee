"""The light pass: each light adds what it reflects into the HDR target (blend ONE,
ONE), reading its numbers from the light table (engine/gpu/lights.py).

  sun                      full screen.
  point, spot, rect, disk  a light volume (a sphere, or a cone for narrow spots) with
                           a scissor rectangle, shading only pixels whose scene surface
                           lies inside it: two-sided stencil marking against a copy of
                           the scene depth, then the volume's back faces where marked
                           (engine/gpu/stencil.py). Depth is reversed with an infinite
                           far plane (engine/view.py), so no volume crosses it; an
                           orthographic camera's volume that crosses its finite far
                           plane shades its scissored screen instead.
  point/spot without a map all in one instanced draw of their spheres (shadowless, or
                           past the shadow maps' memory budget): per-light
                           Python and draw calls would cost more than their few pixels.
Shadow-casting lights read their map from the shadow pass. Volumes are placed
relative to the camera (positions are camera-relative, as the surfaces they light).
Under clustered lighting with the screen passes raster, this pass draws only the
lights with a shadow map this frame (LightPass.drawn).

reads: g_base, g_normal, g_mat, g_emit, g_depth, hdr, view, shadow_maps (optional),
       g_smooth (optional: normals before the normal maps, for the bump map correction),
       g_sheen (optional: the sheen lobes)
writes: hdr, depth_stencil
render passes: adds to DiffDir, GlossDir, Shadow (passes/ambient.py LIGHTING_AOVS)"""
from __future__ import annotations

import math

import numpy as np

from ....core.lights import KINDS, POINT, SPOT, SUN
from ...view import translate
from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from .ambient import (GBUFFER, LIGHTING_AOVS, LIGHTING_TARGETS, bind_gbuffer, surface_defines,
                      lighting_aovs)
from .area_visibility import DEFINE as AREA_VISIBILITY, area_visibility, filtered
from .shadows import set_shadow_uniforms

CONE_SIDES = 24
CONE_MAX_HALF_ANGLE = 75.0   # wider spots use the sphere


def icosphere(level: int) -> np.ndarray:
    """Triangle soup of an icosphere whose faces circumscribe the unit sphere."""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    tris = np.array([[v[i] for i in face] for face in f], float)
    tris /= np.linalg.norm(tris, axis=2, keepdims=True)
    for _ in range(level):
        a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
        ab, bc, ca = [(x + y) / np.linalg.norm(x + y, axis=1, keepdims=True)
                      for x, y in ((a, b), (b, c), (c, a))]
        tris = np.concatenate([np.stack(s, 1) for s in
                               ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    # Scale so the flat faces (not just the vertices) enclose the unit sphere.
    centroid = tris.mean(axis=1)
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    inradius = np.min(np.abs(np.sum(centroid * normal, axis=1)))
    return (tris / inradius).reshape(-1, 3).astype("f4")


def cone(light, length: float) -> np.ndarray:
    """Triangle soup, about the light's position, of a cone enclosing the spot's lit region (height
    `length` along its axis past the light, polygon base circumscribing). A spot with
    a radius lights from every point of its sphere, so the apex moves back until the
    cone contains the cone of every such point: by radius / sin(half angle)."""
    half = math.radians(light.cone_angle)
    ax = light.direction
    back = light.radius / max(math.sin(half), 1e-3)
    length += back
    r = length * math.tan(half) / math.cos(math.pi / CONE_SIDES)
    u = np.cross(ax, [1.0, 0, 0] if abs(ax[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    w = np.cross(ax, u)
    ang = np.arange(CONE_SIDES) * 2 * math.pi / CONE_SIDES
    apex = -ax * back
    ring = apex + ax * length + (np.outer(np.cos(ang), u) + np.outer(np.sin(ang), w)) * r
    center = apex + ax * length
    tris = []
    for i in range(CONE_SIDES):
        a, b = ring[i], ring[(i + 1) % CONE_SIDES]
        tris += [apex, a, b, center, b, a]
    tris = np.array(tris).reshape(-1, 3, 3)
    # Wind every face outward (counter-clockwise seen from outside).
    mid = apex + ax * length * 0.5
    nrm = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    flip = np.sum(nrm * (tris.mean(axis=1) - mid), axis=1) < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return tris.reshape(-1, 3).astype("f4")


class LightPass(Pass):
    name = "lights"
    reads = GBUFFER + ("hdr", "view", "shadow_maps")
    optional = ("g_smooth", "g_sheen", "ao", "field")
    writes = ("hdr", "depth_stencil")

    def __init__(self, ctx, pool, programs, uploads, stencil, table, geometry, environment,
                 contact):
        self.ctx, self.pool, self.programs, self.uploads = ctx, pool, programs, uploads
        self.contact = contact              # shadows.ContactRays
        self.environment = environment      # the split-sum table every BRDF reads
        self.stencil, self.table, self.geometry = stencil, table, geometry
        self.preset = None                  # the frame's being drawn (its taps, its sphere)
        self._spheres = {}          # icosphere level -> vertex buffer
        self._cones = {}            # light path -> (cone params, vertex buffer, vertices)
        self._instances = None      # (light rows, instance buffer) of the batched draw
        self._vaos = {}

    aovs = LIGHTING_AOVS

    def aov_targets(self, frame):
        return LIGHTING_TARGETS if lighting_aovs(frame) else ()

    def needed(self, frame):
        if frame.lighting == "volumes":
            return bool(frame.scene.lights) or lighting_aovs(frame)
        return not frame.compute and bool(self.table.casting)

    def drawn(self, frame, shadow_maps) -> list:
        """The lights this pass draws: every light, or under clustered lighting with
        the screen passes raster (a software rasteriser), those with a shadow map this
        frame. Each of those is a pass of its own in either form (passes/clustered.py
        dispatches it), and its volume shades the same pixels for a fraction of the
        dispatch's time on llvmpipe (docs/gpu.md)."""
        if frame.lighting == "volumes":
            return list(frame.scene.lights)
        return [path for path in self.table.casting if path in shadow_maps]

    def execute(self, frame, board):
        ctx, view = self.ctx, board["view"]
        self.preset = frame.preset
        shadow_maps = board.get("shadow_maps", {})
        self._aovs = lighting_aovs(frame)
        colors = [board["hdr"]] + ([board["aov_diffuse"], board["aov_glossy"], board["aov_shadow"]]
                                   if self._aovs else [])
        fbo = self.pool.framebuffer(colors, depth_stencil=board["depth_stencil"])
        fbo.depth_mask = True
        fbo.use()
        self.stencil.clear()
        # Scene depth into this pass's depth buffer (the shaders sample g_depth), float
        # to float, exactly; the HDR target already holds the ambient pass's light, so
        # colour writes are off.
        ctx.disable(ctx.BLEND)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "1"
        self.stencil.color_writes(False)
        prog = self.programs.get("fullscreen.vert", "depth_copy.frag")
        board["g_depth"].use(UNITS["g_depth"])
        self.programs.fullscreen(prog)
        self.stencil.color_writes(True)
        fbo.depth_mask = False
        fbo.use()
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        self.table.texture.use(UNITS["u_lights"])
        self.environment.bind_tables()
        self.environment.bind_sheen(frame.scene.materials.values())

        batched = []
        for path in self.drawn(frame, shadow_maps):
            light = frame.scene.lights[path]
            R = self.table.ranges[path]
            if light.kind != SUN and R <= 0:
                continue
            if self._batchable(light, R, path in shadow_maps, view):
                batched.append(path)
                continue
            sm = shadow_maps.get(path)
            visibility = None
            if sm is not None and filtered(light):
                visibility = area_visibility(ctx, self.pool, self.programs, frame, board, view,
                                             sm, self.table.index[path])
            fbo.use()
            ctx.enable(ctx.BLEND)
            ctx.blend_func = ctx.ONE, ctx.ONE
            try:
                self._draw_light(frame, board, view, path, light, R, sm, visibility is not None)
            finally:
                ctx.scissor = None
                self.stencil.end()
                if visibility is not None:
                    self.pool.release(visibility)
        for gone in [p for p in self._cones if p not in frame.scene.lights]:
            self._drop_vaos(self._cones[gone][1])
            self._cones.pop(gone)[1].release()
        if batched:
            fbo.use()
            self._draw_batched(frame, board, view, batched)
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)

    def _batchable(self, light, R, shadowed, view):
        return (light.kind in (POINT, SPOT) and not shadowed
                and not _crosses_far_plane(view, light.position - view.origin, R * 1.3))

    def _sphere_vbo(self):
        level = self.preset.ico_level
        if level not in self._spheres:
            self._spheres[level] = self.uploads.buffer(icosphere(level), kind="lights")
        return self._spheres[level]

    def _vao(self, prog, vbo, instances=None):
        key = (prog.extra, id(vbo), id(instances))
        vao = self._vaos.get(key)
        if vao is None:
            content = [(vbo, "3f", "in_pos")]
            if instances is not None:
                content.append((instances, "1i/i", "i_light"))
            vao = self._vaos[key] = self.ctx.vertex_array(prog, content)
        return vao

    def _draw_batched(self, frame, board, view, paths):
        """All batched lights in one draw of their sphere volumes (reads the G-buffer
        and the scene depth). Back faces pass the depth test only where the scene
        surface is in front of them, and the shader's distance test discards surfaces
        in front of the volume, so only pixels inside a volume are shaded; the camera
        may be inside one. No per-light stencil or scissor: one draw has none."""
        ctx = self.ctx
        rows = np.array([self.table.index[p] for p in paths], np.int32)
        if self._instances is None or not np.array_equal(self._instances[0], rows):
            if self._instances is not None:
                self._drop_vaos(self._instances[1])
                self._instances[1].release()
            self._instances = (rows, self.uploads.buffer(rows, kind="lights"))
        kinds = kind_defines(frame.scene.lights[p].kind for p in paths)
        prog = self.programs.get("volume.vert", "light.frag", kinds + ["LIGHTS_INSTANCED"]
                                 + (["WRITE_AOVS"] if self._aovs else [])
                                 + surface_defines(frame, board))
        bind_gbuffer(board, prog, view)
        set_uniform(prog, "mvp", view.view_proj)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<="            # at or behind the scene surface (reversed depth)
        ctx.enable(ctx.CULL_FACE)
        ctx.cull_face = "front"
        self._vao(prog, self._sphere_vbo(), self._instances[1]).render(ctx.TRIANGLES,
                                                                       instances=len(paths))
        ctx.disable(ctx.CULL_FACE)
        ctx.cull_face = "back"
        frame.count("light_volumes", len(paths))
        frame.count("lights_drawn", len(paths))
        frame.count("batched_lights", len(paths))

    def _program(self, frame, board, view, vert, variant, row, sm, light):
        contact = self.contact.defines(frame, board, light) if sm is not None else []
        prog = self.programs.get(vert, "light.frag", variant + (["HAS_SHADOW"] if sm else [])
                                 + contact
                                 + (["WRITE_AOVS"] if self._aovs else [])
                                 + surface_defines(frame, board))
        bind_gbuffer(board, prog, view)
        set_uniform(prog, "light_index", row)
        set_uniform(prog, "light_error", float(frame.options.light_error))  # emitter groups'
        if sm is not None:
            set_shadow_uniforms(prog, sm, self.preset, view.origin)
        return prog

    def _cone_vbo(self, path, light, R):
        params = (tuple(light.axis), light.cone_angle, light.radius, R)
        entry = self._cones.get(path)
        if entry is None or entry[0] != params:
            if entry is not None:
                self._drop_vaos(entry[1])
                entry[1].release()
            data = cone(light, R)
            entry = self._cones[path] = (params, self.uploads.buffer(data, kind="lights"), data)
        return entry[1], entry[2]

    def _draw_light(self, frame, board, view, path, light, R, sm, filtered_shadow=False):
        """One light into the HDR target (reads the G-buffer, depth+stencil, its
        shadow map, or its filtered shadow: area_visibility). Suns shade the screen;
        other lights shade only inside the scissor rectangle of their volume and, via
        the stencil, only pixels whose scene surface lies inside the volume."""
        ctx = self.ctx
        row = self.table.index[path]
        variant = [KINDS[light.kind].shader] + ([AREA_VISIBILITY] if filtered_shadow else [])
        if light.kind == SUN:
            ctx.disable(ctx.DEPTH_TEST)
            self.programs.fullscreen(self._program(frame, board, view, "fullscreen.vert",
                                                   variant, row, sm, light))
            frame.count("lights_drawn")
            return
        use_cone = light.kind == SPOT and light.cone_angle <= CONE_MAX_HALF_ANGLE
        center = np.asarray(light.position, np.float64) - view.origin   # camera-relative
        if use_cone:
            vbo, soup = self._cone_vbo(path, light, R)
            mvp = view.view_proj @ translate(center)
            hull = center + soup.astype(float)
        else:
            vbo = self._sphere_vbo()
            mvp = view.view_proj @ translate(center) @ np.diag([R, R, R, 1.0])
            hull = sphere_hull(center, R)
        rect = screen_rect(view, frame.size, hull)
        if rect is not None and (rect[2] <= 0 or rect[3] <= 0):
            return                                 # wholly off screen
        ctx.scissor = rect
        bound = R / math.cos(math.radians(light.cone_angle)) if use_cone else R * 1.3
        if _crosses_far_plane(view, center, bound):
            # Its back faces would be clipped away: shade the (scissored) screen instead.
            ctx.disable(ctx.DEPTH_TEST)
            self.programs.fullscreen(self._program(frame, board, view, "fullscreen.vert", variant,
                                                   row, sm, light))
            frame.count("lights_drawn")
            return
        # Stencil marking: depth-fail counting of both faces against the scene depth
        # (a face passes in front of the scene: GREATER, depth being reversed).
        mark = self.programs.get("volume.vert", "volume_mark.frag")
        set_uniform(mark, "mvp", mvp)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = ">"
        ctx.disable(ctx.CULL_FACE)
        self.stencil.begin_mark()
        self._vao(mark, vbo).render(ctx.TRIANGLES)
        frame.count("stencil_marks")
        # Shading: back faces (present even with the camera inside), marked pixels only.
        self.stencil.begin_shade()
        ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.CULL_FACE)
        ctx.cull_face = "front"
        prog = self._program(frame, board, view, "volume.vert", variant, row, sm, light)
        set_uniform(prog, "mvp", mvp)
        self._vao(prog, vbo).render(ctx.TRIANGLES)
        self.stencil.end()
        ctx.disable(ctx.CULL_FACE)
        ctx.cull_face = "back"
        frame.count("light_volumes")
        frame.count("lights_drawn")

    def _drop_vaos(self, buffer):
        for key in [k for k in self._vaos if id(buffer) in k[1:]]:
            self._vaos.pop(key).release()

    def release(self):
        for vao in self._vaos.values():
            vao.release()
        for entry in self._cones.values():
            entry[1].release()
        for obj in [*self._spheres.values(), self._instances[1] if self._instances else None]:
            if obj is not None:
                obj.release()
        self._spheres.clear()
        self._vaos.clear()
        self._cones.clear()


def kind_defines(kinds) -> list:
    """The variant that shades these light kinds only (shaders/lights.glsl, core/lights.py
    KINDS' shader defines): a program with every kind's code runs slower for any of them."""
    return sorted({KINDS[kind].shader for kind in kinds})


def volume_hull(light, R, center) -> np.ndarray:
    """Points around a light's volume at a camera-relative centre, for its screen
    rectangle: a narrow spot's cone (as drawn), else the sphere's box."""
    if light.kind == SPOT and light.cone_angle <= CONE_MAX_HALF_ANGLE:
        return center + cone(light, R).astype(float)
    return sphere_hull(center, R)


def sphere_hull(center, R) -> np.ndarray:
    """Corners of a box around a light volume of radius R (its icosphere's faces
    circumscribe the sphere: 1.3 R holds them) at a camera-relative centre."""
    return center + R * 1.3 * np.array(
        [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def screen_rect(view, size, points):
    """Pixel rectangle (x, y, w, h) bounding the projected (camera-relative) points,
    None (the whole screen) when any lies behind the camera's near plane."""
    w, h = size
    clip = (view.view_proj @ np.c_[points, np.ones(len(points))].T).T
    if np.any(clip[:, 3] <= view.camera.near * 0.5):
        return None
    ndc = clip[:, :2] / clip[:, 3:4]
    x0, y0 = np.floor((ndc.min(axis=0) * 0.5 + 0.5) * (w, h)).astype(int) - 1
    x1, y1 = np.ceil((ndc.max(axis=0) * 0.5 + 0.5) * (w, h)).astype(int) + 1
    x0, x1 = max(x0, 0), min(x1, w)
    y0, y1 = max(y0, 0), min(y1, h)
    return (int(x0), int(y0), int(max(x1 - x0, 0)), int(max(y1 - y0, 0)))


def _crosses_far_plane(view, center, radius):
    """Whether a volume (camera-relative centre) reaches the far plane, which only an
    orthographic camera's depth has: a perspective one's is at infinity."""
    cam = view.camera
    if not cam.ortho:
        return False
    z = float(np.dot(center, cam.forward))
    return z + radius >= cam.far * 0.999
