"""Where the first caster behind each texel of an area light's shadow map ends: a
second depth layer, the nearest surface beyond the map's own (depth peeling: the same
opaque casters drawn again, every fragment at or before the map's depth discarded;
shaders/shadow.frag EXIT). The lookup's march (shaders/shadow_lookup.glsl
area_shadow_factor) takes a point of a receiver's ray to the light for a point inside
an occluder only between the two layers, a closed caster's entry and exit. With one
layer, a point up to 1.5 march steps behind the map's surface counted as inside, so a
ray passing just beside a thin slab, or beside a solid's silhouette as the light's
centre sees it, was shadowed: the emissive table's outer penumbra was 30-60% too dark
(docs/rendering.md, "Area-light penumbrae"). An open caster (one plane) has no exit of
its own: the layer then holds what lies behind it, and the 1.5 steps bound it as
before; cut-out and blended casters are not peeled either. Only area lights march, so
only their maps have the layer, and only while the shadow budget has room for it after
every map's own depth (passes/shadows.py): at ultra the demo's four maps fill it, and a
layer that took a light's own map from it would cost that light its shadow."""
from __future__ import annotations

from ....core.lights import DISK, POLYGON, RECT
from ...shadow_plan import tile_sees
from ..programs import UNITS, set_uniform


def has_exits(light) -> bool:
    """Whether a light's map gets the exit layer (the lights whose lookup marches)."""
    return light.kind in (RECT, DISK, POLYGON)


def give_exits(ctx, pool, programs, geometry, maps, drawn, room, clip, set_light,
               boxes=None) -> int:
    """Exit layers for the area lights' maps of `maps` (light path -> (light, its
    ShadowMap), most important first) while `room` bytes of the shadow budget last,
    after every map's own depth: a map left without one marches as it did before the
    layer (shadow_lookup.glsl shadow_exits). `drawn`: the tiles each map drew this frame,
    whose layers are drawn again; a map given a layer now draws it whole.
    `set_light(prog, light, sm)` sets what a caster draw needs; `boxes`: the view's
    world_boxes, whose casters outside a tile it leaves out, as the map's own depth
    does (None: every caster). Returns the draws."""
    draws = 0
    geometry.bind_objects(UNITS["u_objects"])
    for path, (light, sm) in maps.items():
        if not has_exits(light):
            continue
        size = 4 * sm.atlas[0] * sm.atlas[1]
        if size > room:
            release_exits(pool, sm)
            continue
        room -= size
        tiles = range(sm.tiles) if sm.exit is None else drawn.get(path, ())
        for i in tiles:
            seen = None if boxes is None else tile_sees(sm, i, boxes[1], boxes[2])
            draws += _draw_tile(ctx, pool, programs, geometry, sm, i,
                                lambda prog: set_light(prog, light, sm), clip @ sm.mats[i], seen)
    ctx.scissor = None
    ctx.disable(ctx.DEPTH_TEST)
    return draws


def start_tile(ctx, fbo, rect):
    """Draws from here into `rect` (pixels) of the depth target `fbo`: that tile
    cleared to the far depth, scissored, depth-tested nearest first. A map's own depth
    (passes/shadows.py) and its exit layer alike."""
    fbo.viewport = rect
    fbo.use()
    fbo.clear(depth=1.0, viewport=rect)
    ctx.scissor = rect
    ctx.enable(ctx.DEPTH_TEST)
    ctx.depth_func = "<"


def _draw_tile(ctx, pool, programs, geometry, sm, tile, set_light, view_proj, seen) -> int:
    """The exit layer of one tile of map `sm`, whose own depth is drawn; `seen`: the
    casters drawn (DrawCommands.draw_casters)."""
    if sm.exit is None:
        sm.exit = pool.acquire(sm.atlas, "depth")
        sm.exit_raw = ctx.sampler(texture=sm.exit, filter=(ctx.NEAREST, ctx.NEAREST),
                                  compare_func="", repeat_x=False, repeat_y=False)
    start_tile(ctx, pool.framebuffer(depth=sm.exit), sm.tile_pixels(tile))
    prog = programs.get("shadow.vert", "shadow.frag",
                        geometry.commands.object_defines() + ["EXIT"])
    set_light(prog)
    set_uniform(prog, "view_proj", view_proj)
    sm.raw.use(UNITS["shadow_raw"])          # the map's own depth, which it peels
    return geometry.commands.draw_casters(prog, seen)


def release_exits(pool, sm):
    if sm.exit is not None:
        sm.exit_raw.release()
        pool.release(sm.exit)
        sm.exit = sm.exit_raw = None
