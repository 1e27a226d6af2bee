"""The deferred pipeline. Runs on the GL thread; every GL object it makes is released
at the end of the frame (compiled programs stay cached, see shaders.py).

Passes (reads -> writes):
  gbuffer  meshes, materials, textures -> RT0 base+alpha, RT1 normal, RT2 metallic/
           roughness/F0, RT3 emission (RGBA16F), depth (DEPTH24)
  lights   G-buffer + depth -> HDR (RGBA32F), additive (ONE, ONE): the ambient pass
           (dome, emission, background), then one draw per light: full-screen for
           suns, back faces of a light volume with depth test GREATER_EQUAL against a
           copy of the scene depth otherwise (the camera may be inside the volume).
  resolve  HDR + depth -> float32 RGBA output, read back top row first.
"""
from __future__ import annotations

import math
import time

import numpy as np

from . import lights as lt
from . import skinning
from . import shadows
from . import stencil
from .shaders import program, set_uniform
from .textures import TextureCache, read_image_linear

# Quality presets, the one table. Shadows: shadow_size = texels per tile side (a
# cube face, a spot map, one sun cascade; a light's lantern:shadowResolution wins),
# pcf_taps / blocker_taps = PCSS filter and blocker-search samples, cascades = sun
# cascades.
PRESETS = {
    "low": dict(anisotropy=1.0, disk_sides=16, ico_level=1,
                shadow_size=512, pcf_taps=8, blocker_taps=8, cascades=2),
    "medium": dict(anisotropy=4.0, disk_sides=32, ico_level=1,
                   shadow_size=1024, pcf_taps=16, blocker_taps=12, cascades=3),
    "high": dict(anisotropy=8.0, disk_sides=32, ico_level=2,
                 shadow_size=2048, pcf_taps=32, blocker_taps=16, cascades=4),
    "ultra": dict(anisotropy=16.0, disk_sides=32, ico_level=2,
                  shadow_size=4096, pcf_taps=64, blocker_taps=32, cascades=4),
}
MAP_SLOTS = [("diffuseColor", "diffuse", "HAS_DIFFUSE_MAP"), ("metallic", "metallic", "HAS_METALLIC_MAP"),
             ("roughness", "roughness", "HAS_ROUGHNESS_MAP"), ("emissiveColor", "emissive", "HAS_EMISSIVE_MAP"),
             ("opacity", "opacity", "HAS_OPACITY_MAP"), ("normal", "normal", "HAS_NORMAL_MAP")]
WRAP = {"repeat": 0, "mirror": 1, "clamp": 2, "black": 3}
CHANNEL = {"rgb": -1, "r": 0, "g": 1, "b": 2, "a": 3}
CONE_SIDES = 24


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
    """World-space triangle soup of a cone enclosing the spot's lit region (height
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
    apex = light.position - ax * back
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


def disk_polygon(light, sides: int) -> np.ndarray:
    """Equal-area regular polygon for a disk light."""
    R = light.radius * math.sqrt(2 * math.pi / (sides * math.sin(2 * math.pi / sides)))
    ang = np.arange(sides) * 2 * math.pi / sides
    return light.position + (np.outer(np.cos(ang), light.x_axis) + np.outer(np.sin(ang), light.y_axis)) * R


def rect_polygon(light) -> np.ndarray:
    hx, hy = light.x_axis * light.width / 2, light.y_axis * light.height / 2
    c = light.position
    return np.array([c - hx - hy, c + hx - hy, c + hx + hy, c - hx + hy])


class GeometryCache:
    """GL buffers of meshes (with their VAOs and static blend-shape textures), kept
    across the frames of a sequence; joint textures are rewritten in place."""

    def __init__(self):
        self.vbos, self.skin_vbos, self.vaos, self.shapes, self.joints = {}, {}, {}, {}, {}
        self.influences = {}
        self.bounds = {}

    def vao(self, ctx, prog, mesh, stats):
        key = (mesh.key, id(prog))
        vao = self.vaos.get(key)
        if vao is None:
            if mesh.key not in self.vbos:
                self.vbos[mesh.key] = ctx.buffer(mesh.vertices.tobytes())
                stats["meshes_uploaded"] += 1
            content = [(self.vbos[mesh.key], "3f 3f 2f 4f", "in_pos", "in_normal", "in_uv",
                        "in_tangent")]
            if mesh.skin is not None:
                if mesh.key not in self.skin_vbos:
                    data, fmt, names = skinning.vertex_data(mesh)
                    self.skin_vbos[mesh.key] = (ctx.buffer(data), fmt, names)
                buf, fmt, names = self.skin_vbos[mesh.key]
                content.append((buf, fmt, *names))
            vao = self.vaos[key] = ctx.vertex_array(prog, content, skip_errors=True)
        return vao

    def shape_texture(self, ctx, mesh):
        tex = self.shapes.get(mesh.key)
        if tex is None:
            tex = self.shapes[mesh.key] = skinning.shape_texture(ctx, mesh.skin)
        return tex

    def influence_texture(self, ctx, mesh):
        tex = self.influences.get(mesh.key)
        if tex is None:
            tex = self.influences[mesh.key] = skinning.flat_texture(ctx, mesh.skin.point_influences)
        return tex

    def joint_texture(self, ctx, key, pose):
        """One upload per skeleton per frame, however many meshes it drives."""
        tex, stamp = self.joints.get(key, (None, None))
        if stamp is not pose:
            texels = skinning.joint_texels(pose.xforms, pose.dqs)
            if tex is not None and (tex.width, tex.height) == (texels.shape[1], texels.shape[0]):
                tex.write(texels.tobytes())
            else:
                if tex is not None:
                    tex.release()
                tex = skinning.float_texture(ctx, texels)
            self.joints[key] = (tex, pose)
        return tex

    def rest_bounds(self, mesh):
        b = self.bounds.get(mesh.key)
        if b is None:
            p = mesh.vertices[:, :3].astype(np.float64)
            b = self.bounds[mesh.key] = (p.min(axis=0), p.max(axis=0))
        return b

    def release(self):
        for vao in self.vaos.values():
            vao.release()
        for obj in list(self.vbos.values()) + [v[0] for v in self.skin_vbos.values()] + \
                list(self.shapes.values()) + [v[0] for v in self.joints.values()] + \
                list(self.influences.values()):
            obj.release()
        self.__init__()


class FrameRenderer:
    def __init__(self, ctx, scene, width, height, preset, transparent, gpu=None):
        """gpu: a GeometryCache the caller keeps across frames (None: this frame's)."""
        self.ctx, self.scene = ctx, scene
        self.gpu = gpu if gpu is not None else GeometryCache()
        self._own_gpu = gpu is None
        self.size = (int(width), int(height))
        self.opts = PRESETS[preset]
        self.transparent = transparent
        self._unit_sphere = None
        self._draw_bounds = None
        self._owned = []  # GL objects released after the frame
        self.stats = {"meshes_uploaded": 0, "draw_calls": 0, "culled": 0, "lights_drawn": 0,
                      "light_volumes": 0, "shadow_maps": 0, "shadow_passes": 0,
                      "shadow_draws": 0, "stencil_marks": 0}
        cam = scene.camera
        self.view_proj = cam.proj @ cam.view
        self.inv_view_proj = np.linalg.inv(self.view_proj)

    def own(self, obj):
        self._owned.append(obj)
        return obj

    def release(self):
        for obj in reversed(self._owned):
            obj.release()
        self._owned.clear()

    def render(self):
        timings = {}
        ctx = self.ctx
        t0 = time.perf_counter()
        try:
            self.textures = TextureCache(ctx, self.opts["anisotropy"])
            self._gbuffer_pass()
            ctx.finish()
            t1 = time.perf_counter()
            self._light_pass()
            ctx.finish()
            t2 = time.perf_counter()
            rgba = self._resolve_pass()
            t3 = time.perf_counter()
        finally:
            self.textures.release()
            self.release()
            if self._own_gpu:
                self.gpu.release()
            ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        timings.update(gbuffer=t1 - t0, lights=t2 - t1, resolve=t3 - t2)
        return rgba, timings

    # --- G-buffer ----------------------------------------------------------------
    def _gbuffer_pass(self):
        ctx, size = self.ctx, self.size
        self.g_base = self.own(ctx.texture(size, 4, dtype="f2"))
        self.g_normal = self.own(ctx.texture(size, 4, dtype="f2"))
        self.g_mat = self.own(ctx.texture(size, 4, dtype="f2"))
        self.g_emit = self.own(ctx.texture(size, 4, dtype="f2"))
        self.g_depth = self.own(ctx.depth_texture(size))
        for t in (self.g_base, self.g_normal, self.g_mat, self.g_emit, self.g_depth):
            t.filter = (ctx.NEAREST, ctx.NEAREST)
        self.g_depth.compare_func = ""
        fbo = self.own(ctx.framebuffer(
            color_attachments=[self.g_base, self.g_normal, self.g_mat, self.g_emit],
            depth_attachment=self.g_depth))
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        ctx.disable(ctx.BLEND)
        ctx.cull_face = "back"

        planes = skinning.frustum_planes(self.view_proj)
        bounds = self.draw_bounds()
        for i, draw in enumerate(self.scene.draws):
            if i not in bounds:
                continue                    # no triangles
            mesh = self.scene.meshes[draw.mesh_key]
            lo, hi = bounds[i]
            if skinning.aabb_outside(planes, lo, hi):
                self.stats["culled"] += 1   # frustum culling: no draw call at all
                continue
            world = draw.world
            m3 = world[:3, :3]
            det = np.linalg.det(m3)
            normal_matrix = np.linalg.inv(m3).T if abs(det) > 1e-30 else m3
            # A mirroring transform turns counter-clockwise triangles clockwise.
            ctx.front_face = "cw" if det < 0 else "ccw"
            if mesh.double_sided:
                ctx.disable(ctx.CULL_FACE)
            else:
                ctx.enable(ctx.CULL_FACE)
            skin_defs = skinning.defines(mesh.skin)
            for mat_index, first, count in mesh.ranges:
                mat = mesh.materials[mat_index]
                defines = [flag for name, _, flag in MAP_SLOTS if name in mat.maps] + skin_defs
                prog = program(ctx, "gbuffer.vert", "gbuffer.frag", defines)
                vao = self.mesh_vao(prog, mesh)
                set_uniform(prog, "model", world)
                set_uniform(prog, "view_proj", self.view_proj)
                set_uniform(prog, "normal_matrix", normal_matrix)
                self._material_uniforms(prog, mat)
                self.bind_skin(prog, draw, mesh)
                vao.render(ctx.TRIANGLES, vertices=count, first=first)
                self.stats["draw_calls"] += 1
        ctx.front_face = "ccw"
        ctx.disable(ctx.CULL_FACE)
        # Material samplers stay bound to their units otherwise, and would override
        # the G-buffer textures' own (mip-less) filtering in later passes.
        ctx.clear_samplers(0, len(MAP_SLOTS) + 1)

    # --- geometry, for every pass that draws meshes ----------------------------------
    def mesh_vao(self, prog, mesh):
        """A VAO of `mesh` for `prog` (any vertex shader reading in_pos, in_normal,
        in_uv, in_tangent and skinning.glsl's inputs); uploads the mesh on first use."""
        return self.gpu.vao(self.ctx, prog, mesh, self.stats)

    def bind_skin(self, prog, draw, mesh):
        """This frame's joint texture, blend-shape offsets and weights for a skinned
        draw (nothing for a static mesh). The program needs skinning.defines(mesh.skin)."""
        skin = mesh.skin
        if skin is None:
            return
        ctx = self.ctx
        n_active = 0
        if skin.shape_offsets is not None:
            self.gpu.shape_texture(ctx, mesh).use(skinning.UNIT_SHAPES)
            texels, n_active = skinning.active_texels(skin, draw.shapes)
            self.own(skinning.float_texture(ctx, texels)).use(skinning.UNIT_ACTIVE)
        if skin.has_joints:
            pose = self.scene.skeletons[skin.skel_key]
            self.gpu.joint_texture(ctx, skin.skel_key, pose).use(skinning.UNIT_JOINTS)
            if skin.point_influences is not None:
                self.gpu.influence_texture(ctx, mesh).use(skinning.UNIT_INFLUENCES)
        skinning.set_skin_uniforms(prog, skin, n_active, set_uniform)

    def draw_bounds(self):
        """{draw index: world AABB} of every draw with triangles, skinned meshes as
        posed this frame. Computed once a frame: culling and shadow fitting share it."""
        if self._draw_bounds is None:
            self._draw_bounds = {}
            for i, draw in enumerate(self.scene.draws):
                mesh = self.scene.meshes.get(draw.mesh_key)
                if mesh is not None and mesh.ranges:
                    self._draw_bounds[i] = self.world_bounds(draw, mesh)
        return self._draw_bounds

    def geometry_bounds(self):
        """World AABB of everything drawn this frame (the stage's own bounds miss
        skinning), or None without geometry. Shadow maps fit it."""
        boxes = list(self.draw_bounds().values())
        if not boxes:
            return None
        return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)

    def world_bounds(self, draw, mesh):
        """World AABB of a draw this frame (skinned meshes: from their joints)."""
        lo, hi = self.gpu.rest_bounds(mesh)
        if mesh.skin is not None:
            pose = self.scene.skeletons.get(mesh.skin.skel_key) if mesh.skin.has_joints else None
            lo, hi = skinning.local_bounds(mesh.skin, pose, draw.shapes, lo, hi)
        return skinning.transform_aabb(lo, hi, draw.world)

    def _material_uniforms(self, prog, mat):
        set_uniform(prog, "u_diffuse", mat.diffuse)
        set_uniform(prog, "u_metallic", mat.metallic)
        set_uniform(prog, "u_roughness", mat.roughness)
        set_uniform(prog, "u_ior", mat.ior)
        set_uniform(prog, "u_emissive", mat.emissive)
        set_uniform(prog, "u_opacity", mat.opacity)
        set_uniform(prog, "u_opacity_threshold", mat.opacity_threshold)
        for unit, (name, short, _) in enumerate(MAP_SLOTS, start=1):
            ref = mat.maps.get(name)
            if ref is None:
                continue
            tex = self.textures.get(ref.path, ref.colorspace)
            tex.use(unit)
            self.textures.sampler(ref.wrap_s, ref.wrap_t).use(unit)
            set_uniform(prog, f"t_{short}", unit)
            set_uniform(prog, f"m_{short}.wrap", (WRAP.get(ref.wrap_s, 0), WRAP.get(ref.wrap_t, 0)))
            set_uniform(prog, f"m_{short}.scale", tuple(ref.scale))
            set_uniform(prog, f"m_{short}.bias", tuple(ref.bias))
            set_uniform(prog, f"m_{short}.channel", CHANNEL.get(ref.channel, -1))

    # --- lights ------------------------------------------------------------------
    def _bind_gbuffer(self, prog):
        for unit, (name, tex) in enumerate([("g_base", self.g_base), ("g_normal", self.g_normal),
                                            ("g_mat", self.g_mat), ("g_emit", self.g_emit),
                                            ("g_depth", self.g_depth)]):
            tex.use(unit)
            set_uniform(prog, name, unit)
        cam = self.scene.camera
        set_uniform(prog, "inv_view_proj", self.inv_view_proj)
        set_uniform(prog, "cam_pos", cam.position)
        set_uniform(prog, "cam_forward", cam.forward)
        set_uniform(prog, "cam_ortho", bool(cam.ortho))

    def _fullscreen(self, prog):
        vao = self.own(self.ctx.vertex_array(prog, []))
        vao.render(self.ctx.TRIANGLES, vertices=3)

    def _light_pass(self):
        ctx, size = self.ctx, self.size
        self.hdr = self.own(ctx.texture(size, 4, dtype="f2"))
        self.hdr.filter = (ctx.NEAREST, ctx.NEAREST)
        fbo = self.own(ctx.framebuffer(color_attachments=[self.hdr]))
        # Depth + stencil: the scene depth for volume tests, the stencil for marking.
        depth_stencil = self.own(stencil.DepthStencil(fbo, size))
        fbo.depth_mask = True
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        depth_stencil.clear()

        # Scene depth into this pass's depth buffer (the shaders sample g_depth).
        ctx.disable(ctx.BLEND)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "1"
        prog = program(ctx, "fullscreen.vert", "depth_copy.frag")
        self.g_depth.use(0)
        set_uniform(prog, "g_depth", 0)
        self._fullscreen(prog)
        fbo.depth_mask = False
        fbo.use()

        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD

        # Ambient: dome, emission, background. Emission is added here and only here.
        ctx.disable(ctx.DEPTH_TEST)
        dome = self.scene.dome
        defines = ["HAS_DOME_MAP"] if dome is not None and dome.texture else []
        prog = program(ctx, "fullscreen.vert", "ambient.frag", defines)
        self._bind_gbuffer(prog)
        set_uniform(prog, "has_dome", dome is not None)
        set_uniform(prog, "transparent", bool(self.transparent))
        if dome is not None:
            set_uniform(prog, "dome_sh", np.asarray(dome.sh, "f4"))
            set_uniform(prog, "dome_radiance", dome.radiance)
            if dome.texture:
                img = read_image_linear(dome.texture, "auto")
                tex = self.own(ctx.texture((img.shape[1], img.shape[0]), 4,
                                           np.ascontiguousarray(img, "f4").tobytes(), dtype="f4"))
                tex.filter = (ctx.LINEAR, ctx.LINEAR)
                tex.repeat_y = False
                tex.use(5)
                set_uniform(prog, "dome_map", 5)
                set_uniform(prog, "dome_to_local", dome.rotation.T)
        self._fullscreen(prog)

        self._light_vaos = {}
        batched = []
        for light in self.scene.lights:
            R = lt.volume_radius(light)
            if light.kind != "distant" and R <= 0:
                continue
            if self._batchable(light, R):
                batched.append((light, R))
                continue
            # Shadow pass (meshes -> this light's depth atlas), only for casters.
            sm = None
            if light.shadow and self.scene.draws:
                sm = shadows.render(self, light, R)
                if sm is not None:
                    self.stats["shadow_maps"] += 1
            fbo.use()
            ctx.enable(ctx.BLEND)
            ctx.blend_func = ctx.ONE, ctx.ONE
            try:
                self._draw_light(light, R, sm)
            finally:
                ctx.scissor = None
                stencil.end()
                if sm is not None:
                    sm.release()
        if batched:
            fbo.use()
            self._draw_batched_lights(batched)
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)

    def _batchable(self, light, R):
        """Shadowless point and spot lights whose sphere volume lies before the far
        plane share one instanced draw: per-light work in Python and draw calls would
        otherwise cost more than shading their few pixels."""
        return (light.kind in ("sphere", "spot") and not (light.shadow and self.scene.draws)
                and not self._crosses_far_plane(light.position, R * 1.3))

    def _draw_batched_lights(self, batched):
        """All batched lights in one draw of their sphere volumes (reads the G-buffer
        and the scene depth). Back faces pass the depth test only where the scene
        surface is in front of them, and the shader's distance test discards surfaces
        in front of the volume, so only pixels inside a volume are shaded; the camera
        may be inside one. No per-light stencil or scissor: one draw has none."""
        ctx = self.ctx
        rows = np.zeros((len(batched), 16), "f4")
        for i, (light, R) in enumerate(batched):
            flags = (1 if light.soft_falloff else 0) + (2 if light.kind == "spot" else 0)
            rows[i] = [*light.position, R, *np.asarray(light.color, float), light.radius,
                       *light.direction, light.cos_half, light.cone_softness, light.diffuse,
                       light.specular, flags]
        if self._unit_sphere is None:
            self._unit_sphere = self.own(ctx.buffer(icosphere(self.opts["ico_level"]).tobytes()))
        prog = program(ctx, "volume.vert", "light.frag", ["LIGHT_SPHERE", "LIGHTS_INSTANCED"])
        self._bind_gbuffer(prog)
        set_uniform(prog, "mvp", self.view_proj)
        instances = self.own(ctx.buffer(rows.tobytes()))
        vao = self.own(ctx.vertex_array(prog, [
            (self._unit_sphere, "3f", "in_pos"),
            (instances, "4f 4f 4f 4f/i", "i_pos_range", "i_color_radius", "i_axis_cos", "i_params"),
        ]))
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = ">="
        ctx.enable(ctx.CULL_FACE)
        ctx.cull_face = "front"
        vao.render(ctx.TRIANGLES, instances=len(batched))
        ctx.disable(ctx.CULL_FACE)
        ctx.cull_face = "back"
        self.stats["light_volumes"] += len(batched)
        self.stats["lights_drawn"] += len(batched)
        self.stats["batched_lights"] = self.stats.get("batched_lights", 0) + len(batched)

    def _light_program(self, vert, light, variant, R, sm):
        prog = program(self.ctx, vert, "light.frag", [variant] + (["HAS_SHADOW"] if sm else []))
        self._bind_gbuffer(prog)
        self._light_uniforms(prog, light, R)
        if sm is not None:
            sm.set_uniforms(prog, self.opts)
        return prog

    def _vao(self, prog, vbo):
        key = (id(prog), id(vbo))
        if key not in self._light_vaos:
            self._light_vaos[key] = self.own(self.ctx.vertex_array(prog, [(vbo, "3f", "in_pos")]))
        return self._light_vaos[key]

    def _draw_light(self, light, R, sm):
        """One light into the HDR target (reads the G-buffer, depth+stencil, its
        shadow map). Suns shade the screen; other lights shade only inside the
        scissor rectangle of their volume and, via the stencil, only pixels whose
        scene surface lies inside the volume."""
        ctx = self.ctx
        if light.kind == "distant":
            ctx.disable(ctx.DEPTH_TEST)
            self._fullscreen(self._light_program("fullscreen.vert", light, "LIGHT_DISTANT", R, sm))
            self.stats["lights_drawn"] += 1
            return
        variant = "LIGHT_SPHERE" if light.kind in ("sphere", "spot") else "LIGHT_AREA"
        use_cone = light.kind == "spot" and light.cone_angle <= 75.0
        if use_cone:
            vbo = self.own(ctx.buffer(cone(light, R).tobytes()))
            mvp = self.view_proj
            hull = np.frombuffer(vbo.read(), "f4").reshape(-1, 3).astype(float)
        else:
            if self._unit_sphere is None:
                self._unit_sphere = self.own(ctx.buffer(icosphere(self.opts["ico_level"]).tobytes()))
            vbo = self._unit_sphere
            model = np.diag([R, R, R, 1.0])
            model[:3, 3] = light.position
            mvp = self.view_proj @ model
            hull = light.position + R * 1.3 * np.array(
                [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        rect = self._scissor(hull)
        if rect is not None and (rect[2] <= 0 or rect[3] <= 0):
            return                                 # wholly off screen
        ctx.scissor = rect
        bound = R / math.cos(math.radians(light.cone_angle)) if use_cone else R * 1.3
        if self._crosses_far_plane(light.position, bound):
            # Its back faces would be clipped away: shade the (scissored) screen instead.
            ctx.disable(ctx.DEPTH_TEST)
            self._fullscreen(self._light_program("fullscreen.vert", light, variant, R, sm))
            self.stats["lights_drawn"] += 1
            return
        # Stencil marking: depth-fail counting of both faces against the scene depth.
        mark = program(ctx, "volume.vert", "volume_mark.frag")
        set_uniform(mark, "mvp", mvp)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        ctx.disable(ctx.CULL_FACE)
        stencil.begin_mark()
        self._vao(mark, vbo).render(ctx.TRIANGLES)
        self.stats["stencil_marks"] += 1
        # Shading: back faces (present even with the camera inside), marked pixels only.
        stencil.begin_shade()
        ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.CULL_FACE)
        ctx.cull_face = "front"
        prog = self._light_program("volume.vert", light, variant, R, sm)
        set_uniform(prog, "mvp", mvp)
        self._vao(prog, vbo).render(ctx.TRIANGLES)
        stencil.end()
        ctx.disable(ctx.CULL_FACE)
        ctx.cull_face = "back"
        self.stats["light_volumes"] += 1
        self.stats["lights_drawn"] += 1

    def _scissor(self, points):
        """Pixel rectangle (x, y, w, h) bounding the projected points, None (the whole
        screen) when any lies behind the camera's near plane."""
        w, h = self.size
        clip = (self.view_proj @ np.c_[points, np.ones(len(points))].T).T
        if np.any(clip[:, 3] <= self.scene.camera.near * 0.5):
            return None
        ndc = clip[:, :2] / clip[:, 3:4]
        x0, y0 = np.floor((ndc.min(axis=0) * 0.5 + 0.5) * (w, h)).astype(int) - 1
        x1, y1 = np.ceil((ndc.max(axis=0) * 0.5 + 0.5) * (w, h)).astype(int) + 1
        x0, x1 = max(x0, 0), min(x1, w)
        y0, y1 = max(y0, 0), min(y1, h)
        return (int(x0), int(y0), int(max(x1 - x0, 0)), int(max(y1 - y0, 0)))

    def _crosses_far_plane(self, center, radius):
        cam = self.scene.camera
        z = float(np.dot(center - cam.position, cam.forward))
        return z + radius >= cam.far * 0.999

    def _light_uniforms(self, prog, light, R):
        set_uniform(prog, "light_color", np.asarray(light.color, float))
        set_uniform(prog, "light_pos", light.position)
        set_uniform(prog, "light_axis", light.direction)
        set_uniform(prog, "light_diffuse", light.diffuse)
        set_uniform(prog, "light_specular", light.specular)
        set_uniform(prog, "light_range", R)
        if light.kind in ("sphere", "spot"):
            set_uniform(prog, "light_radius", light.radius)
            set_uniform(prog, "soft_falloff", bool(light.soft_falloff))
            set_uniform(prog, "is_spot", light.kind == "spot")
            set_uniform(prog, "cos_half", light.cos_half)
            set_uniform(prog, "spot_blend", light.cone_softness)
        elif light.kind in ("rect", "disk"):
            if light.kind == "rect":
                verts = rect_polygon(light)
                half, area = (light.width / 2, light.height / 2), light.width * light.height
            else:
                verts = disk_polygon(light, self.opts["disk_sides"])
                half, area = (light.radius, 0.0), math.pi * light.radius ** 2
            poly = np.zeros((32, 3), "f4")
            poly[:len(verts)] = verts
            set_uniform(prog, "poly", poly)
            set_uniform(prog, "n_poly", len(verts))
            set_uniform(prog, "light_x", light.x_axis)
            set_uniform(prog, "light_y", light.y_axis)
            set_uniform(prog, "half_size", half)
            set_uniform(prog, "is_disk", light.kind == "disk")
            set_uniform(prog, "light_area", area)

    # --- resolve -----------------------------------------------------------------
    def _resolve_pass(self):
        ctx, (w, h) = self.ctx, self.size
        out = self.own(ctx.texture((w, h), 4, dtype="f4"))
        fbo = self.own(ctx.framebuffer(color_attachments=[out]))
        fbo.use()
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        prog = program(ctx, "fullscreen.vert", "resolve.frag")
        self.hdr.use(0)
        self.g_depth.use(1)
        set_uniform(prog, "hdr", 0)
        set_uniform(prog, "g_depth", 1)
        set_uniform(prog, "transparent", bool(self.transparent))
        self._fullscreen(prog)
        data = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
        rgba = data.reshape(h, w, 4)[::-1].copy()  # GL rows run bottom-up
        return np.nan_to_num(rgba, nan=0.0, posinf=0.0, neginf=0.0)
