"""The glass pass: transmissive surfaces (Material.alpha == "glass",
lantern:transmission), drawn after the opaque lighting and before the blended
surfaces, over the lit frame. Each glass object's front faces are lit forward as the
transparency pass lights its surfaces (the same draws: the dome, emission and
unshadowed lights, then each shadowed light; passes/transparency.py), with the diffuse
share 1 - transmission and the Fresnel reflection of the dome and the lights; the first
draw adds what the glass lets through (shaders/glass.glsl):

- GL 4.3+ (compute): the refracted ray is followed through the object's own surfaces
  with the ray tracer (Renderer.tracer): Snell's law at every interface, total
  internal reflection inside, Fresnel's transmittance and the tint (the base colour)
  at each crossing. What the ray leaving it meets is read from the lit frame where it
  is on screen and not hidden there, else the dome along the ray.
- GL 3.3 and 4.1 (no compute): one interface, in screen space (EEVEE's refraction): the
  refracted ray runs as far as the opaque surface behind the pixel, and the lit frame
  is read there (the dome off screen).

What lies behind is blurred by the roughness: a mip level of a copy of the lit frame,
a roughness level of the prefiltered dome. With no bounces (Cycles' Max Bounces 0:
RenderSettings.bounces_for) no light goes through, as in Cycles: the glass shows its
reflections only.

Without bounces glass is also drawn in the G-buffer (its diffuse share; passes/gbuffer.py),
so it hides and occludes what lies behind it as Cycles' opaque-to-paths glass does, and
this pass draws over it with the traced reflection.

Depth: tested in the shader against the opaque depth (g_depth, sampled, so not
attached; equal passes: the glass itself without bounces), never written; objects back to front, front faces only, each replacing the
pixel. The frame read behind is the opaque one: a second glass object behind the first
is not seen through it, and blended surfaces are drawn after (over) the glass.

Nothing is drawn, copied or traced when no visible object has a glass material.

reads: hdr, g_depth, view, shadow_maps and tessellated (optional)   writes: hdr"""
from __future__ import annotations

import numpy as np

from ..lit_copy import LitCopy
from ..programs import UNITS, set_uniform
from ..pattern import material_variant
from .transparency import TransparencyPass


NORMALS_BINDING = 14               # shaders/glass.glsl glass_normals


class GlassPass(TransparencyPass):
    name = "glass"
    kind = "glass"
    stat = "glass"
    culled = ("back",)                # front faces only: the way in

    def __init__(self, ctx, pool, programs, geometry, textures, lights, environment, depth,
                 uploads, tracer, proc):
        super().__init__(ctx, pool, programs, geometry, textures, lights, environment, depth)
        self.uploads = uploads
        self.tracer = tracer           # scene -> Raytracer (Renderer.tracer); None: no compute
        self.normals = None            # the traced triangles' corner normals (binding 14)
        self._normals_of = None        # what they were made from
        # The lit frame's mip-mapped copy.
        self.behind = LitCopy(ctx, pool, programs, proc, compute=tracer is not None)
        self._frame = None             # this frame's (traced, refract, eye)

    def _target(self, frame, board):
        """The lit frame copied (and its mip levels made) to read behind the glass; the
        HDR image drawn into without a depth attachment (the shader tests g_depth)."""
        hdr = board["hdr"]
        refract = frame.glass_refracts
        # Copied only where something is read behind the glass.
        behind = self.behind.copy(hdr) if refract else self.behind.made(hdr)
        fbo = self.pool.framebuffer([hdr])
        board["g_depth"].use(UNITS["g_depth"])
        behind.use(UNITS["hdr"])
        # The tracer wherever compute shaders are (RenderSettings.compute False: the
        # one-interface form, as GL 3.3 and 4.1 draw it).
        traced = self.tracer is not None and frame.options.compute is not False
        if traced:
            tracer = self.tracer(frame.scene)
            tracer.bind()
            self._corner_normals(tracer).bind_to_storage_buffer(NORMALS_BINDING)
        self._frame = (traced, refract, board["view"].origin)
        return fbo

    def _corner_normals(self, tracer):
        """(T, 3, 4) float32 object-space normals of the tracer's triangles, in its
        order: a mesh's own vertex normals, so the faces inside refract as smoothly as
        the front is shaded; zero (the triangle's own normal, glass.glsl) for a skinned
        mesh (its normals move with the pose) and a subdivision surface's patches."""
        made_of = tuple((key, id(b.mesh), b.first_triangle, len(b.triangles))
                        for key, b in tracer.bottoms.items())
        if self.normals is not None and made_of == self._normals_of:
            return self.normals
        out = np.zeros((max(tracer.triangle_count, 1), 3, 4), np.float32)
        for b in tracer.bottoms.values():
            mesh = b.mesh
            if mesh.skin is None and mesh.patches is None and len(mesh.indices):
                corners = mesh.vertices[:, 3:6][mesh.indices.reshape(-1, 3)]
                out[b.first_triangle:b.first_triangle + len(corners), :, :3] = corners
        if self.normals is not None:
            self.normals.release()
        self.normals = self.uploads.buffer(out, kind="raytrace")
        self._normals_of = made_of
        return self.normals

    def _program(self, frame, mat, defines):
        traced, refract, eye = self._frame
        prog = self.programs.get("gbuffer.vert", "glass_traced.frag" if traced else "glass.frag",
                                 list(defines) + ["WRITE_INDEX"],
                                 generated=material_variant(mat))
        set_uniform(prog, "u_refract", refract)
        set_uniform(prog, "u_eye", tuple(float(c) for c in eye))
        set_uniform(prog, "u_behind_lods", self.behind.lods)
        set_uniform(prog, "u_behind", UNITS["hdr"])
        set_uniform(prog, "u_opaque_depth", UNITS["g_depth"])
        return prog

    def release(self):
        if self.normals is not None:
            self.normals.release()
            self.normals = self._normals_of = None
        self.behind.release()
        super().release()
