"""The ambient pass: the light that is everywhere, once, full screen: the dome
(spherical-harmonics irradiance for diffuse, the prefiltered environment and the
split-sum table for the specular lobe and the coat; engine/gpu/environment.py keeps
them per map), emission (added here and only here), and the dome as the background.
Ambient occlusion, when the AO pass ran, dims the dome's light only. With an
irradiance field (passes/irradiance.py) the diffuse light is the field's instead of the
dome's: the field's rays that escape bring the dome, so it is counted once. In a frame
with the glossy bounce (passes/reflections.py) the base lobe's dome reflection is left
to that pass. It starts the HDR target.

reads: g_base, g_normal, g_mat, g_emit, g_depth, view, ao, field (optional), g_smooth (optional:
       the normals before the normal maps, for the bump map correction), g_sheen
       (optional: the sheen lobes)   writes: hdr
render passes (with the light and reflection passes): DiffDir, DiffInd, GlossDir, GlossInd,
               Env, Shadow: see LIGHTING_AOVS"""
from __future__ import annotations

from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program
from .ao import occludes

GBUFFER = ("g_base", "g_normal", "g_mat", "g_emit", "g_depth")

# The lighting render passes (core/passes.py), all their targets made together when one
# is asked for (the shaders write them as one set of outputs). The ambient pass starts
# them, the light pass and the reflection pass add to them:
#   DiffDir   diffuse light leaving the surface, albedo included: every light's (its
#             shadow applied) and, in a frame without an irradiance field, the dome's
#             (its occlusion applied)
#   DiffInd   the same of the irradiance field's light, which replaces the dome's: the
#             ambient pass's diffuse output goes here when the frame has a field
#   GlossDir  the specular lobe's and the clearcoat's light: the lights', the dome's
#             reflection, and the dome a reflected ray meets where it escapes
#   GlossInd  the rest of the glossy bounce (passes/reflections.py); 0 without it
#   Env       the dome seen directly where nothing is drawn; 0 on surfaces
#   Shadow    light reaching the surface with shadows over light without, summed over
#             the lights (Rec. 709 luminance, grey; 1 where no light reaches)
# With neither FXAA nor post, Combined = DiffDir + DiffInd + GlossDir + GlossInd + Env
# + Emit.
LIGHTING_AOVS = {"DiffDir": ("aov_diffuse", 0), "DiffInd": ("aov_diffuse_indirect", 0),
                 "GlossDir": ("aov_glossy", 0), "GlossInd": ("aov_glossy_indirect", 0),
                 "Env": ("aov_env", 0), "Shadow": ("aov_shadow", 0)}
LIGHTING_TARGETS = tuple(target for target, _ in LIGHTING_AOVS.values())


def lighting_aovs(frame) -> bool:
    return any(name in frame.aovs for name in LIGHTING_AOVS)


def bind_gbuffer(board, prog, view):
    """The G-buffer and the camera, as every screen-space lighting pass reads them
    (positions from depth are camera-relative: lib.glsl), and the frame's ambient
    occlusion when it has one (surface_defines' BASE_OCCLUSION reads it)."""
    for name in GBUFFER + tuple(n for n in ("g_smooth", "g_sheen") if n in board):
        board[name].use(UNITS[name])
    if "ao" in board:
        board["ao"].use(UNITS["ao_tex"])
    view.set_camera(prog)


def surface_defines(frame, board) -> list:
    """The lighting shaders' variant for what this frame's G-buffer holds: the normals
    before the normal maps (BUMP_CORRECTION: the bump map correction, passes/gbuffer.py),
    and base colours that take the frame's ambient occlusion (BASE_OCCLUSION: an Ambient
    Occlusion node's Color on Base Color; g_emit.a marks those pixels), and sheen lobes
    (SHEEN: shaders/sheen.glsl)."""
    defines = (["BUMP_CORRECTION"] if "g_smooth" in board else []) + \
        (["SHEEN"] if "g_sheen" in board else [])
    if "ao" in board and occludes(frame) and \
            any(m.base_occlusion for m in frame.scene.materials.values()):
        defines.append("BASE_OCCLUSION")
    return defines


class AmbientPass(Pass):
    name = "ambient"
    reads = GBUFFER + ("view",)
    optional = ("ao", "g_smooth", "g_sheen", "field")
    writes = ("hdr",)
    aovs = LIGHTING_AOVS

    def aov_targets(self, frame):
        return LIGHTING_TARGETS if lighting_aovs(frame) else ()

    def __init__(self, ctx, pool, programs, environment):
        self.ctx, self.pool, self.programs, self.environment = ctx, pool, programs, environment

    def execute(self, frame, board):
        ctx = self.ctx
        dome = frame.scene.dome
        env = self.environment.prepare(dome)    # draws into its own targets: first
        if dome is not None and dome.texture in self.environment.failed:
            warnings = frame.scene.warnings.setdefault(dome.name, [])
            line = (f"{dome.name}: dome texture {dome.texture!r} unreadable "
                    f"({self.environment.failed[dome.texture]}); using the uniform colour")
            if line not in warnings:
                warnings.append(line)
        aovs = lighting_aovs(frame)
        # This pass's diffuse light is the dome's (DiffDir) or, under the field, all the
        # field's (DiffInd). The passes it does not write start at 0: the light pass
        # adds to Shadow, the reflection pass writes GlossInd in the frames it runs.
        diffuse = "aov_diffuse_indirect" if "field" in board else "aov_diffuse"
        written = (diffuse, "aov_glossy", "aov_env")
        if aovs:
            clear = self.pool.framebuffer([board[n] for n in LIGHTING_TARGETS
                                           if n not in written])
            clear.use()
            clear.clear(0.0, 0.0, 0.0, 0.0)
        targets = [board["hdr"]] + ([board[n] for n in written] if aovs else [])
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        # The AO pass may run only for its render pass; the image uses it when the
        # preset has occlusion.
        ao = board.get("ao") if occludes(frame) else None
        defines = (["HAS_DOME_MAP"] if env is not None else []) + (["HAS_AO"] if ao else []) + \
            (["WRITE_AOVS"] if aovs else []) + surface_defines(frame, board) + \
            (["IRRADIANCE_FIELD"] if "field" in board else []) + \
            (["GLOSSY_BOUNCE"] if "reflections" in frame.stats["passes"] else [])
        prog = screen_program(self.programs, "ambient", defines, frame.compute, len(targets))
        bind_gbuffer(board, prog, board["view"])
        self.environment.bind(prog, dome, env)
        self.environment.bind_sheen(frame.scene.materials.values())
        set_uniform(prog, "has_dome", dome is not None)
        if "field" in board:
            board["field"].bind(prog)
            set_uniform(prog, "field_eye", board["view"].origin)
        set_uniform(prog, "transparent", bool(frame.transparent))
        run_screen(ctx, self.programs, self.pool, prog, targets, frame.compute)
