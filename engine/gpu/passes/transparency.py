"""The transparency pass: blended surfaces (Material.alpha == "blend"), drawn after
the lights over the lit opaque image, back to front, each lit forward by what lights
the deferred surfaces: the dome term, every light of the light table, and the shadow
maps (shaders/transparent.frag calls the same shader functions as the ambient and
light passes, never a copy).

Compositing is premultiplied "over": rgb' = alpha * L + (1 - alpha) * rgb and
a' = alpha + (1 - alpha) * a, alpha scaling everything the surface sends (Cycles
mixes the whole Principled BSDF, emission included, with a transparent BSDF). The
HDR target's alpha, the opaque coverage the ambient pass wrote, so ends as
1 - (1 - coverage) prod(1 - alpha): a transparent film's alpha. A surface's light is
split over draws: the first (dome, emission, up to MAX_FORWARD_LIGHTS unshadowed
lights) blends "over", then each shadowed light (with its map) and any further
unshadowed ones add; "over" is linear in its source, so the sum composites as one
draw would.

Depth: tested against the opaque depth (reversed: nearer is GREATER), never
written, so blended surfaces hide behind opaque ones and leave the AOVs (Depth,
Normal, IndexOB, IndexMA, Emit: the G-buffer's) to the opaque surface behind them.

Order: objects are sorted back to front by the distance from the eye to the centre
of their world box (along the view axis for an orthographic camera), ties by prim
path, so any view draws a consistent order. Within an object, its back faces are
drawn before its front faces (double-sided meshes), each in index order: a closed
convex mesh (a glass box, a bubble) is then right from any view. What a sort per
object cannot order is left as EEVEE's Blended mode leaves it: two meshes that
intersect, or one whose own surfaces overlap in depth beyond back-before-front (a
mesh folded over itself), blend in that order and not per pixel; a PointInstancer's
instances sort as one object (their union box). Opaque texels of blended materials
with an opacity map are the G-buffer's, ordered exactly by depth.

Nothing is drawn, and nothing allocated, when no visible object has a blended
material.

reads: hdr, g_depth, view, shadow_maps and tessellated (optional)   writes: hdr"""
from __future__ import annotations

import numpy as np

from ....core.lights import SUN
from ...scene import OPAQUE_ALPHA
from ..framegraph import Pass
from ..pattern import material_variant
from ..programs import UNITS, set_uniform
from .gbuffer import map_defines, set_material
from .shadows import set_shadow_uniforms

MAX_FORWARD_LIGHTS = 32       # shaders/transparent.frag


class TransparencyPass(Pass):
    name = "transparency"
    reads = ("hdr", "g_depth", "view")
    optional = ("shadow_maps", "tessellated")
    writes = ("hdr",)
    kind = "blend"                    # the Material.alpha this pass draws
    fragment = "transparent.frag"
    stat = "transparent"              # its stats: <stat>_objects, <stat>_draws
    culled = ("front", "back")        # a double-sided mesh's faces culled, draw by draw

    def __init__(self, ctx, pool, programs, geometry, textures, lights, environment, depth):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.geometry, self.textures, self.lights = geometry, textures, lights
        self.environment, self.depth = environment, depth
        self.preset = None             # the frame's being drawn (its shadow filter taps)

    def needed(self, frame) -> bool:
        blended = materials_of(frame.scene, self.kind)
        return bool(blended) and any(m in blended for d in self.geometry.draws.values()
                                     for m, _, _ in d.ranges)

    def execute(self, frame, board):
        ctx, view = self.ctx, board["view"]
        self.preset = frame.preset
        layers = self.back_to_front(frame, view)
        frame.count(f"{self.stat}_objects", len(layers))
        if not layers:
            return
        fbo = self._target(frame, board)
        fbo.use()
        ctx.enable(ctx.DEPTH_TEST | ctx.BLEND)
        ctx.depth_func = ">"              # nearer than the opaque surface (reversed depth)
        ctx.blend_equation = ctx.FUNC_ADD
        self.depth.far_clip(True)
        self.geometry.bind_objects(UNITS["u_objects"])
        self.lights.texture.use(UNITS["u_lights"])
        shadow_maps = board.get("shadow_maps", {})
        dome = frame.scene.dome
        env = self.environment.prepare(dome)     # the ambient pass's, kept for the session
        try:
            for d, lo, hi in layers:
                self._draw_object(frame, view, d, lo, hi, shadow_maps, (dome, env))
        finally:
            fbo.depth_mask = True
            ctx.front_face = "ccw"
            ctx.cull_face = "back"
            ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
            self.depth.far_clip(False)

    def _target(self, frame, board):
        """The framebuffer drawn into: the HDR image, depth-tested against the opaque
        depth (not written)."""
        fbo = self.pool.framebuffer([board["hdr"]], depth=board["g_depth"])
        fbo.depth_mask = False
        return fbo

    def _program(self, frame, mat, defines):
        """The program that draws `mat` with these variant defines."""
        return self.programs.get("gbuffer.vert", self.fragment, defines,
                                 generated=material_variant(mat))

    def back_to_front(self, frame, view) -> list:
        """[(draw object, world box lo, hi)] with this pass's ranges, in view, far first."""
        blended = materials_of(frame.scene, self.kind)
        draws, lo, hi = view.boxes
        pick = [i for i, d in enumerate(draws) if any(m in blended for m, _, _ in d.ranges)]
        if not pick:
            return []
        lo, hi = lo[pick], hi[pick]
        seen = ~view.outside(lo, hi)
        centre = (lo + hi) * 0.5 - view.origin
        cam = view.camera
        far = centre @ cam.forward if cam.ortho else np.linalg.norm(centre, axis=1)
        order = sorted((i for i in range(len(pick)) if seen[i]),
                       key=lambda i: (-far[i], draws[pick[i]].path))
        return [(draws[pick[i]], lo[i], hi[i]) for i in order]

    def _draw_object(self, frame, view, d, lo, hi, shadow_maps, environment):
        ctx = self.ctx
        materials = frame.scene.materials
        store = self.geometry.meshes[d.mesh_key][0]
        ranges = [(materials[m], first, count) for m, first, count in d.ranges
                  if materials[m].alpha == self.kind]
        lit, shadowed = self._lights_reaching(frame.scene, lo, hi, shadow_maps)
        ctx.front_face = "cw" if d.mirrored else "ccw"
        ctx.enable(ctx.CULL_FACE)
        # Back faces first (culling the front ones), then front faces.
        for culled in (("back",) if d.cull else self.culled):
            ctx.cull_face = culled
            for mat, first, count in ranges:
                chunks = [lit[i:i + MAX_FORWARD_LIGHTS]
                          for i in range(0, len(lit), MAX_FORWARD_LIGHTS)] or [[]]
                for k, rows in enumerate(chunks):
                    self._draw(frame, view, d, store, mat, first, count, rows, None,
                               environment, ambient=(k == 0))
                for row, sm in shadowed:
                    self._draw(frame, view, d, store, mat, first, count, [row], sm,
                               environment, ambient=False)

    def _lights_reaching(self, scene, lo, hi, shadow_maps):
        """(rows of unshadowed lights, [(row, shadow map)]) that reach the box."""
        lit, shadowed = [], []
        for path, light in scene.lights.items():
            R = self.lights.ranges.get(path, 0.0)
            if light.kind != SUN:
                if R <= 0:
                    continue
                p = np.asarray(light.position, float)
                if np.sum((np.clip(p, lo, hi) - p) ** 2) > R * R:
                    continue
            row = self.lights.index[path]
            sm = shadow_maps.get(path)
            if sm is None:
                lit.append(row)
            else:
                shadowed.append((row, sm))
        return lit, shadowed

    def _draw(self, frame, view, d, store, mat, first, count, rows, sm, environment,
              ambient):
        ctx = self.ctx
        dome, env = environment
        defines = map_defines(mat) + (["HAS_DOME_MAP"] if env is not None else []) + \
            (["AMBIENT"] if ambient else []) + (["HAS_SHADOW"] if sm is not None else []) + \
            (["SHEEN"] if mat.has_sheen else [])
        prog = self._program(frame, mat, defines)
        set_uniform(prog, "view_proj", view.view_proj)
        set_uniform(prog, "u_far", view.far_clip)
        view.set_camera(prog)
        set_uniform(prog, "u_size", tuple(float(s) for s in frame.size))
        set_material(prog, mat, self.textures, 0.0, frame.supersample == 1)
        set_uniform(prog, "u_opaque_alpha", OPAQUE_ALPHA if "opacity" in mat.maps or mat.opacity_varies
                    else 2.0)
        self.environment.bind(prog, dome, env)    # and the split-sum table every draw needs
        self.environment.bind_sheen([mat])
        set_uniform(prog, "has_dome", dome is not None)
        if "light_rows" in prog:
            prog["light_rows"].value = [int(r) for r in rows] + \
                [0] * (MAX_FORWARD_LIGHTS - len(rows))
        set_uniform(prog, "n_lights", len(rows))
        if sm is not None:
            set_shadow_uniforms(prog, sm, self.preset, view.origin)
        if ambient:
            ctx.blend_func = ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA
        else:
            ctx.blend_func = ctx.ONE, ctx.ONE
        prog["u_object"].value = int(d.oid)
        store.vao(prog).render(ctx.TRIANGLES, vertices=int(count), first=int(first),
                               instances=int(d.n))
        frame.count(f"{self.stat}_draws")


def materials_of(scene, kind) -> set:
    """The names of the scene's materials whose Material.alpha is `kind`."""
    return {name for name, m in scene.materials.items() if m.alpha == kind}
