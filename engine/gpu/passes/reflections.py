"""The glossy bounce: surfaces reflect the lit scene, not only the dome and the lights.
It runs after the opaque lighting (the ambient and light passes) and before the glass
and blended surfaces, over a mip-mapped copy of the lit frame (engine/gpu/lit_copy.py,
as the glass pass reads what lies behind it), and replaces each pixel's reflection of
the dome (the base lobe's: the coat keeps the dome's) with, by roughness
(shaders/reflections.glsl):

- sharp lobes (roughness up to 0.25, blended into the rough ones by 0.45): the lobe's
  dominant ray traced with the ray tracer (engine/gpu/raytracer.py); what it meets read
  from the lit frame where that is on screen and not hidden, blurred to the mip level of
  the lobe's cone's footprint; the dome over the lobe where it escapes; else as a rough
  reflection;
- rough reflections: the irradiance field's irradiance along the lobe (over pi: the
  field read as prefiltered radiance, Majercik et al. 2021) where the frame has a field
  (passes/irradiance.py), else the dome's reflection as today;
weighted by the same split-sum albedo as the dome's reflection it replaces.

Only when the frame's bounces have a glossy bounce (RenderSettings.bounces_for), some
material has a specular lobe (`reflects`), and on
GL 4.3 (compute shaders, which the tracer needs; the pass is a compute dispatch whatever
the frame's form, so both forms take it): GL 3.3 and 4.1 reflect the dome and the
lights only, as with no bounces. The render passes take the change split as Cycles
splits light: the dome met by a ray that escapes (or the dome's reflection, where a
rough lobe has no field to read) is added to GlossDir; what the ray meets in the lit
frame, and the field's light, are GlossInd; so they add up to the image.

reads: g_base, g_normal, g_mat, g_emit, g_depth, hdr, view, ao, field, g_smooth and
       g_sheen (optional)   writes: hdr
render passes: GlossDir (added to in place, as the light passes add to it), GlossInd"""
from __future__ import annotations

from ..framegraph import Pass
from ..lit_copy import LitCopy
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program
from .ambient import GBUFFER, LIGHTING_AOVS, bind_gbuffer, lighting_aovs, surface_defines
from .ao import occludes


def reflects(material) -> bool:
    """Whether a material has a base specular lobe (which the pass changes): a metal
    (its value, map or network), or a dielectric of IOR other than 1 (its F0 is the IOR's:
    shaders/material.glsl)."""
    fed = material.pattern is not None and material.pattern.feeds("metallic")
    return material.ior != 1.0 or material.metallic > 0.0 or "metallic" in material.maps \
        or fed


class ReflectionPass(Pass):
    name = "reflections"
    reads = GBUFFER + ("hdr", "view")
    optional = ("ao", "g_smooth", "g_sheen", "field")
    writes = ("hdr",)
    aovs = {name: LIGHTING_AOVS[name] for name in ("GlossDir", "GlossInd")}

    def __init__(self, ctx, pool, programs, environment, tracer, proc):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.environment = environment
        self.tracer = tracer           # scene -> Raytracer (Renderer.tracer); None: no compute
        self.lit = LitCopy(ctx, pool, programs, proc, compute=tracer is not None)

    def needed(self, frame) -> bool:
        # A dispatch in either form of the frame (RenderSettings.compute), as the field's.
        return self.tracer is not None and frame.options.bounces_for(frame.scene).glossy_bounces > 0 and \
            bool(frame.scene.instances) and any(map(reflects, frame.scene.materials.values()))

    def execute(self, frame, board):
        dome = frame.scene.dome
        env = self.environment.prepare(dome)
        lit = self.lit.copy(board["hdr"])
        ao = "ao" in board and occludes(frame)
        defines = (["HAS_DOME_MAP"] if env is not None else []) + (["HAS_AO"] if ao else []) + \
            surface_defines(frame, board) + (["IRRADIANCE_FIELD"] if "field" in board else [])
        targets = [board["hdr"]]
        if lighting_aovs(frame):   # GlossDir read and stored in place, GlossInd written
            defines.append("WRITE_AOVS")
            targets += [board["aov_glossy"], board["aov_glossy_indirect"]]
        prog = screen_program(self.programs, "reflections", defines, compute=True,
                              outputs=len(targets))
        view = board["view"]
        bind_gbuffer(board, prog, view)
        self.environment.bind(prog, dome, env)
        set_uniform(prog, "has_dome", dome is not None)
        if "field" in board:
            board["field"].bind(prog)
        self.tracer(frame.scene).bind()
        lit.use(UNITS["hdr"])
        set_uniform(prog, "u_lit", UNITS["hdr"])
        set_uniform(prog, "u_lit_lods", self.lit.lods)
        if lighting_aovs(frame):
            board["aov_glossy"].use(UNITS["post_src"])
            set_uniform(prog, "u_glossy", UNITS["post_src"])
        set_uniform(prog, "view_proj", view.view_proj)
        set_uniform(prog, "u_eye", view.origin)
        self.ctx.disable(self.ctx.BLEND)
        run_screen(self.ctx, self.programs, self.pool, prog, targets, True)

    def release(self):
        self.lit.release()
