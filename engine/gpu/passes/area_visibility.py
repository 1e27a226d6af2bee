"""An area light's shadow, filtered (docs/rendering.md, "Area-light penumbrae"): a
screen pass computes each pixel's visible fraction of the light with taps
interleaved over 4 x 4 pixel blocks (shaders/area_visibility.glsl), and a depth-aware
blur over the block (shaders/area_visibility_blur.glsl) averages its 16 sets of taps,
never across an edge, nor wider than the penumbra, nor across more than the taps'
noise; the light's own draw (shaders/light.frag, lights.comp: AREA_VISIBILITY) reads
the result at its pixel. Without it each pixel's 16 taps on a 2 m light made the
penumbra a black-and-white dither. Not a pass of its own: the light volumes
(passes/lights.py) and the clustered dispatches (passes/clustered.py) call it for each
area light with a map, just before they shade that light. Transparent surfaces, which
the G-buffer does not hold, keep the per-pixel lookup (shaders/transparent.frag).

reads: the G-buffer and g_depth, the light table, the light's shadow map
writes: a texture of the G-buffer's size (x: visibility), released by the caller"""
from __future__ import annotations

from ....core.lights import DISK, POLYGON, RECT
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program
from .ambient import bind_gbuffer, surface_defines
from .shadows import set_shadow_uniforms

DEFINE = "AREA_VISIBILITY"          # the light programs' variant that reads the result


def filtered(light) -> bool:
    """Whether a light's shadow goes through this filter (rect and disk area lights, and
    emissive meshes, shadowed as an area light over their box: engine/emitters.py)."""
    return light.kind in (RECT, DISK, POLYGON)


def area_visibility(ctx, pool, programs, frame, board, view, sm, row):
    """The filtered visibility of the light at light-table `row` (shadow map `sm`),
    bound to UNITS["area_visibility"]; the caller releases it (pool.release) after
    shading the light. Leaves blending and the depth test off."""
    ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
    size = board["g_depth"].size
    raw = pool.acquire(size, "rgba32f")
    out = pool.acquire(size, "rgba32f")
    prog = screen_program(programs, "area_visibility",
                          ["LIGHT_AREA", "HAS_SHADOW", "AREA_INTERLEAVED"]
                          + surface_defines(frame, board), frame.compute)
    bind_gbuffer(board, prog, view)
    set_shadow_uniforms(prog, sm, frame.preset, view.origin)
    set_uniform(prog, "light_index", row)
    run_screen(ctx, programs, pool, prog, [raw], frame.compute)
    blur = screen_program(programs, "area_visibility_blur", (), frame.compute)
    raw.use(UNITS["visibility_tex"])
    view.set_camera(blur)
    # Pixels per world unit at view depth 1 (perspective) or anywhere (orthographic).
    set_uniform(blur, "pixel_scale", 0.5 * size[1] * float(view.camera.proj[1][1]))
    set_uniform(blur, "taps", float(frame.preset.pcf_taps))
    run_screen(ctx, programs, pool, blur, [out], frame.compute)
    pool.release(raw)
    out.use(UNITS["area_visibility"])
    frame.count("area_visibility_passes")
    return out
