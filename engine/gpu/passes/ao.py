"""The ambient-occlusion pass (docs/design.md, Ambient occlusion): screen-space occlusion of the dome's light
by a horizon search (shaders/ao.glsl), then a depth-aware blur (shaders/ao_blur.glsl), each a screen
pass's body (engine/gpu/screen.py) run in the frame's form.
The ambient pass multiplies the dome's diffuse light by it, and its specular light by
the share of the specular lobe its visibility cone lets through; lights and emission
are never occluded here (lights have their shadows).

The search radius is Blender's AO distance (the world's `lantern:aoDistance`, scene
units; 10 when unset, Blender's default), reaching at most across the whole image on
screen (a room's walls occlude each other from far across it); the preset sets the
slices (rays) and steps per side (core/presets.py).

Measured against Cycles (ao_corner, world light only, bounces 0; relative L1 of the
image at ultra): this horizon search 0.102, a ray-marched hemisphere SSAO with as
many samples 0.075 on that scene, but the rays darken flat and convex surfaces that
nothing occludes (a grazing plane to 0.84 on average, a sphere's rim to 0.71), so
every other reference scene got worse with them (furnace 0.002 -> 0.031 FLIP, the
diffuse environment sphere 0.019 -> 0.036, 02_suzanne 0.024 -> 0.029). The horizon
search is kept; what it misses is geometry off screen.
Runs when the scene has a dome and the preset has AO, or the AO render pass is asked
for.

The search runs once per block of the drawn image, from the block's centre pixel, and
the blur upsamples it depth-aware to the drawn size: a block is the preset's ao_block
output pixels a side (2 at low and medium, 1 at high and ultra), each k x k sub-pixels
in a frame supersampled k times. The occlusion it finds varies over the distance
radius, far wider than a pixel (GTAO in UE and EEVEE runs at reduced resolution too).
Measured in docs/gpu.md ("Passes to budget") and docs/rendering.md ("Presets").

Each sample hides the directions from its surface point to the point THICKNESS x the
distance behind it (a visibility bit mask per slice, Therrien et al. 2023), not all
the directions beyond (GTAO's horizon). One more slice, along the surface's specular
lobe (its roughness from g_mat, its shape from the split-sum table), gives the share
of the lobe the scene leaves open: the occlusion of the dome's reflections
(shaders/ao.glsl).

In a frame with the irradiance field the diffuse light is the field's, which the
occlusion does not dim: unless the AO render pass or a material's Ambient Occlusion
node asks for it, only the specular slice is searched (the occlusion is 1); the near
field (passes/near_field.py) runs the same search within half the probe spacing.

reads: g_depth, g_normal, g_mat, view, field (optional)   writes: ao (RGBA32F:
occlusion, specular occlusion); its search (RGBA32F: occlusion and the specular share's two sums, scratch)
comes from the pool at the search's size
render passes: AO (the blurred occlusion, grey)"""
from __future__ import annotations

from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program

DEFAULT_DISTANCE = 10.0      # Blender's world.light_settings.distance default
MAX_SCREEN_FRACTION = 2.0
# An occluder's assumed depth along the view, as a share of the AO distance (2 for
# Blender's default 10). A horizon alone takes every occluder for infinitely thick: a
# cube seen past another lost 56% of the dome where Cycles' loses 17%
# (28_shapekeys_anim: HDR-FLIP 0.0098 -> 0.0024 with a fifth; a tenth, 0.0017, but the
# AO corner's medium error rose from 0.150 to 0.197; a fifth keeps it at 0.150).
THICKNESS = 0.2


def occludes(frame) -> bool:
    """Whether this frame's image has ambient occlusion (the AO pass may also run only
    for its render pass)."""
    return (frame.scene.dome is not None and frame.preset.ao_slices > 0
            and frame.options.ambient_occlusion)


def search_setup(pool, prog, frame, view, radius: float, block: int, steps: int):
    """Sets the horizon search's uniforms on `prog` (shaders/ao.glsl, either variant:
    the occlusion's, or the near field's) for a search within `radius` (scene units),
    once per `block` x `block` pixels, `steps` samples a side (the preset's, for the
    one or the other); returns (its block, pixels a side, of the drawn image; its raw
    target from the pool, to release)."""
    preset, (w, h) = frame.preset, frame.size
    cam = view.camera
    step = max(int(frame.supersample), 1) * max(int(block), 1)
    search = (-(-w // step), -(-h // step))
    frame.stats["ao_searches"] += search[0] * search[1]
    raw = pool.acquire(search, "rgba32f")
    view.set_camera(prog)
    set_uniform(prog, "u_step", step)
    set_uniform(prog, "radius", radius)
    set_uniform(prog, "thickness", THICKNESS * radius)
    # Pixels per world unit at view depth 1 (perspective) or anywhere (orthographic).
    set_uniform(prog, "pixel_scale", 0.5 * h * float(cam.proj[1][1]))
    set_uniform(prog, "max_pixels", float((w * w + h * h) ** 0.5))
    set_uniform(prog, "slices", max(preset.ao_slices, 1))
    set_uniform(prog, "steps", max(int(steps), 1))
    return step, raw


def diffuse_unused(frame, board) -> bool:
    """Whether nothing reads this frame's diffuse occlusion: its diffuse light is the
    irradiance field's (passes/irradiance.py), which the occlusion does not dim, and
    neither the AO render pass nor an Ambient Occlusion node on a base colour asks for
    it. Only the specular occlusion is searched then."""
    return "field" in board and "AO" not in frame.aovs and \
        not any(m.base_occlusion for m in frame.scene.materials.values())


def occlusion_unused(frame, board) -> bool:
    """Whether nothing reads this frame's occlusion at all: not its diffuse occlusion
    (diffuse_unused), nor its specular occlusion: the glossy bounce's pass
    (passes/reflections.py) reflects the scene in place of the base lobe's dome
    reflection, and no surface has a coat, whose dome reflection it would dim. The pass
    then searches nothing and leaves no occlusion on the board (the passes after it
    read it as optional: without it, nothing occluded)."""
    return diffuse_unused(frame, board) and "reflections" in frame.stats["passes"] and \
        not any(m.clearcoat > 0.0 for m in frame.scene.materials.values())


class AoPass(Pass):
    name = "ao"
    reads = ("g_depth", "g_normal", "g_mat", "view")
    optional = ("field",)
    writes = ("ao",)
    aovs = {"AO": ("aov_ao", 0)}

    def __init__(self, ctx, pool, programs, environment):
        self.ctx, self.pool, self.programs, self.environment = ctx, pool, programs, environment

    def needed(self, frame):
        return occludes(frame) or "AO" in frame.aovs

    def execute(self, frame, board):
        if occlusion_unused(frame, board):
            self.pool.release(board.pop("ao"))
            return
        ctx, view = self.ctx, board["view"]
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        board["g_depth"].use(UNITS["g_depth"])
        board["g_normal"].use(UNITS["g_normal"])
        board["g_mat"].use(UNITS["g_mat"])
        self.environment.lut.use(UNITS["dfg_lut"])
        dome = frame.scene.dome
        distance = getattr(dome, "ao_distance", None) or DEFAULT_DISTANCE
        prog = screen_program(self.programs, "ao",
                              ["SPECULAR_ONLY"] if diffuse_unused(frame, board) else [],
                              frame.compute)
        step, raw = search_setup(self.pool, prog, frame, view, float(distance),
                                 frame.preset.ao_block, frame.preset.ao_steps)
        run_screen(ctx, self.programs, self.pool, prog, [raw], frame.compute)
        targets = [board["ao"]] + [board[t] for t in self.aov_targets(frame)]
        prog = screen_program(self.programs, "ao_blur", ["WRITE_AOV"] if len(targets) > 1 else [],
                              frame.compute, len(targets))
        raw.use(UNITS["ao_tex"])
        view.set_camera(prog)
        set_uniform(prog, "u_step", step)
        run_screen(ctx, self.programs, self.pool, prog, targets, frame.compute)
        self.pool.release(raw)
