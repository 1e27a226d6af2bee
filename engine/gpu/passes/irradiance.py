"""The irradiance field pass: the light that bounces off diffuse surfaces, as a grid of
probes over the scene's bounds, or cascades about the camera where they are large
(Majercik et al. 2019, "Dynamic Diffuse Global Illumination with Ray-Traced Irradiance
Fields"; 2021, "Scaling Probe-Based Real-Time Dynamic GI for Production"). The ambient
pass reads it per pixel (shaders/irradiance_field.glsl) in place of the dome's diffuse
light: the dome reaches surfaces through the rays that escape, so the sky is counted once.

An update traces the preset's rays from every probe with the ray tracer
(engine/gpu/raytracer.py; shaders/irradiance_trace.comp), shades each hit with its
emission, the light table's lights (each seen by a shadow ray, so no shadow map is
needed at hits and none leaks), and its albedo times the field as it was (the bounces
so far), or the dome where a ray escapes; then writes each probe's octahedral maps of
irradiance, of the mean distance and its square, and of the planes of the nearest hits
about each direction, of all the build's updates (which say what a wall hides;
near_cone, shaders/irradiance_blend.comp), moves probes out of walls and switches off
those inside geometry. The light at the hits that does not change from one update to
the next (emission, the lights, the dome) is averaged over all the build's updates,
each of new rays; only the bounces come from the last update (a probe moved starts that
mean again). Each update adds one bounce: a field is the scene's diffuse bounces of them
from nothing (a Build). A still and every frame of a sequence run all of it in the
frame, so they render it converged. A viewport's frames (RenderSettings.progressive_field)
run at most the preset's BUDGET of rays, a block of probes after the last, showing the
last complete update meanwhile: an update spread over frames reads the same complete
field and writes what one frame's writes, so the frames converge to the still's field.

The field is kept while nothing it depends on changes (lights, geometry, materials,
the dome, the bounces, the preset; the grids cover the traced triangles' bounds, and
where those are large, cascades follow the camera: engine/probe_grids.py): stats
field_updates counts the updates a frame completed, field_rays the rays it traced
(a probe's, not their shadow rays), field_pending those left to converge. Only on GL
4.3 (compute shaders), when the frame's bounces have a diffuse bounce and the scene has
surfaces and something to light them (else the direct image, no tracer); a hit's
albedo, emission and glass: engine/gpu/field_tables.py.
reads: view   writes: field (the Field: bind it into a shading program)"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ....core.presets import PRESETS
from ...bounces import surfaces_light_each_other, would_bounce
from ...probe_grids import GRIDS, grids, placement
from ..field_tables import HitTables, instance_sides, material_table, transmits
from ..framegraph import Pass
from ..programs import UNITS, set_uniform, set_uniform_array

TEXELS = 8                   # shaders/irradiance_field.glsl FIELD_TEXELS
TILE = TEXELS + 2
TILES_PER_LINE = 64
GROUP = 64                   # shaders/irradiance_trace.comp's local size
BIAS = 0.3                   # the read's self-shadowing bias, a share of the spacing
# Probes along the bounds' longest side, and rays a probe an update, by preset.
PROBES = {"low": 4, "medium": 8, "high": 10, "ultra": 12}
RAYS = {"low": 64, "medium": 128, "high": 192, "ultra": 256}
# The rays of a build's updates that a texel's cone of nearest hits holds, on average
# (near_cone): the wall test's evidence (shaders/irradiance_field.glsl field_hidden).
NEAR_RAYS = 4
# A viewport frame's rays at most (RenderSettings.progressive_field), by preset: the
# field converges over frames, a block of probes a frame (docs/rendering.md).
BUDGET = {"low": 4096, "medium": 8192, "high": 12288, "ultra": 16384}
RANK = tuple(PRESETS)        # presets, coarsest first
ALL_BARRIERS = 0xFFFFFFFF
FIELD_UNITS = ("field_irradiance", "field_distance", "field_probes", "field_materials",
               "field_rays", "field_planes")


def density(frame) -> str:
    """The preset whose probes and rays a frame's field takes: under a final gather,
    which reads the field only at its rays' hits (later bounces, a block's rays
    averaged), the next coarser one's (docs/rendering.md); else the frame's own."""
    name = frame.preset.name
    return RANK[max(RANK.index(name) - 1, 0)] if frame.options.gathers() else name


def unbind_samplers(ctx):
    """The field's units without sampler objects: the G-buffer pass leaves material
    maps' samplers (mipmapped filtering) on the units the field shares with them, and a
    sampler's mipmap filter makes the field's textures, which have no mipmaps,
    incomplete: they would read as 0."""
    for name in FIELD_UNITS:
        ctx.clear_samplers(UNITS[name], UNITS[name] + 1)


def rotation(k: int) -> np.ndarray:
    """A random rotation for update k (the same k, the same rays: renders repeat)."""
    q, r = np.linalg.qr(np.random.default_rng(k).normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def near_cone(rays: int) -> float:
    """The cosine of the cone about a texel's direction that holds NEAR_RAYS of a
    probe's `rays` on average (all its build's updates': a texel's nearest hits are
    those of every update traced from the probe's place, shaders/irradiance_blend.comp);
    fixed over a build. A fixed 14 degrees held one or two of an update's 128 rays and
    none in over a third of the texels at 64: a wall a probe sees at a grazing angle was
    met beyond a point it hides, or not at all (a sealed room's floor lit through its
    walls). Now e^-4 of the cones hold none (64 rays: 29 degrees; 512: 10). Where rays
    abound the cone narrows: 14 degrees at 512 rays hid more points seen past a nearer
    surface's edge (the table under a ball, the floor by a table's legs)."""
    return 1.0 - 2.0 * NEAR_RAYS / rays


def atlas_size(n: int) -> tuple:
    """The size of the atlas of n probes' tiles."""
    return (TILES_PER_LINE * TILE, -(-n // TILES_PER_LINE) * TILE)


def _rows(values, dtype):
    """GRIDS rows of `values` (a grid's vector each), the rest 0: a uniform array's."""
    out = np.zeros((GRIDS,) + np.shape(values[0]), dtype)
    out[:len(values)] = values
    return out


@dataclass
class Field:
    """The field's textures and grids (engine/probe_grids.py), as a shading program reads
    them."""
    irradiance: object
    distance: object
    probes: object
    planes: object               # two hits' planes per distance texel
    grids: list

    def bind(self, prog, light=None):
        unbind_samplers(self.irradiance.ctx)
        # `light`: another Field of these grids, read through this one's walls.
        (light or self).irradiance.use(UNITS["field_irradiance"])
        self.distance.use(UNITS["field_distance"])
        self.probes.use(UNITS["field_probes"])
        self.planes.use(UNITS["field_planes"])
        g = self.grids
        set_uniform(prog, "field_grids", len(g))
        set_uniform_array(prog, "field_lo", _rows([x.first for x in g], np.float32))
        set_uniform_array(prog, "field_step", _rows([x.step for x in g], np.float32))
        set_uniform_array(prog, "field_counts", _rows([x.counts for x in g], np.int32))
        set_uniform_array(prog, "field_first", _rows(
            np.cumsum([0] + [x.probes for x in g])[:-1], np.int32))
        set_uniform_array(prog, "field_region_lo", _rows([x.region_lo for x in g], np.float32))
        set_uniform_array(prog, "field_region_hi", _rows([x.region_hi for x in g], np.float32))
        set_uniform(prog, "field_tiles", TILES_PER_LINE)
        set_uniform(prog, "field_bias", BIAS)

    def release(self):
        for tex in (self.irradiance, self.distance, self.probes, self.planes):
            tex.release()


@dataclass
class Build:
    """A field being made: `updates` updates of its grid's n probes, in order, each of
    `rays` rays a probe, reading the last complete update (`prev`) and writing `target`;
    `k` the update under way, `probe` its next probe. `steady`: per atlas texel, the mean
    over the updates so far of the light they do not bring (shaders/irradiance_blend.comp)."""
    key: tuple
    version: int
    grids: list                  # engine/probe_grids.py Grids
    n: int
    rays: int
    updates: int
    ray_tex: object
    steady: object
    hits: HitTables              # what its rays' hits are shaded with
    k: int = 0
    probe: int = 0
    prev: object = None
    target: object = None

    def rays_left(self) -> int:
        return ((self.updates - self.k) * self.n - self.probe) * self.rays

    def release(self):
        for res in (self.ray_tex, self.steady, self.hits):
            if res is not None:
                res.release()


class IrradiancePass(Pass):
    name = "irradiance"
    reads = ("view",)
    writes = ("field",)

    def __init__(self, ctx, uploads, programs, lights, environment, textures, tracer,
                 compute: bool):
        self.ctx, self.uploads, self.programs = ctx, uploads, programs
        self.textures = textures     # MaterialTextures: a map's mean colour
        self.lights, self.environment = lights, environment
        self.tracer, self.compute = tracer, compute   # tracer(scene): Renderer.tracer
        self.field = None            # the Field frames read: the last complete one
        self.shown = None            # (key, version, converged) of what it holds
        self.build = None            # the Build under way (its updates not all run)
        self.pool = []               # Fields made, reused by later updates and builds
        self.version = 0             # counts what it depends on changing (note)
        self.bounds = (None, None)   # (version, the traced bounds then)
        self._key = None             # what the last build was made for
        self.stale = True            # what it holds changed since (note)
        self.touched = False         # materials changed since: their table is compared
        self.table = None            # the materials' albedo and emission it was built with
        self.seconds = 0.0           # the last frame's field CPU seconds (GPU work waited for)
        self.warnings = []           # without compute shaders: that the bounce is off
        self.lit_each_other = None   # surfaces_light_each_other's answer (None: ask again)
        self.hits = None             # the HitTables of the field shown: bind_hits
        self.fewer = None            # the field shown's update before it (None: one bounce)

    def needed(self, frame) -> bool:
        if not would_bounce(frame, self._light_each_other):
            return False
        if not self.compute:
            line = ("bounces: the diffuse bounce needs compute shaders (GL 4.3), which this "
                    "context lacks; the scene is lit directly (bounces 0)")
            self.warnings = [line]
            return False
        return True

    def execute(self, frame, board):
        view = board["view"]
        scene, bounces = frame.scene, frame.options.bounces_for(frame.scene)
        # A headlight (the default rig) shines along the view: its field follows it.
        along = tuple(view.camera.forward) if any(
            light.headlight for light in scene.lights.values()) else None
        if self._key is not None and not self.stale and self.touched:
            # Only materials changed: the field holds their albedo and emission alone
            # (a pattern's parameters, a roughness, leave it as it is).
            tracer = self.tracer(frame.scene)
            self.stale = not np.array_equal(
                material_table(frame.scene, tracer.materials, self.textures), self.table)
        self.touched = False
        if self.stale:
            self.version, self.stale = self.version + 1, False
        if self.bounds[0] != self.version:
            # Over what is traced, as its triangles lie (a skinned mesh's drawn box is
            # padded by its joints': F12's deformed copy and the file's rig would get
            # two grids).
            tracer = self.tracer(scene)
            self.bounds = (self.version, tracer.bounds if tracer.bounds is not None
                           else view.bounds)
        # The cascades' place about the camera (None: one grid) is part of what a
        # field is made for.
        key = (bounces.diffuse_bounces, density(frame), along,
               placement(*self.bounds[1], view.camera.position, view.camera.forward))
        progressive = frame.options.progressive_field
        if self.build is not None and self.build.version != self.version:
            self._drop_build()           # made for what has changed since
        enough = self._serves(self.shown, key, progressive)
        if not enough and not self._serves(self.build and (self.build.key, self.build.version,
                                                           True), key, progressive):
            self._start(frame, view, key, bounces.diffuse_bounces)
        t0 = time.perf_counter()
        rays = 0
        if self.build is not None and (progressive or not enough):
            budget = BUDGET.get(frame.preset.name, BUDGET["medium"]) if progressive else None
            rays = self._run(frame, budget)
        frame.stats["field_rays"] = rays
        frame.stats["field_pending"] = 0 if self.build is None else self.build.rays_left()
        if rays:
            self.ctx.finish()
            self.seconds = time.perf_counter() - t0
            frame.timings["field_build"] = self.seconds
        if self.field is not None:
            board["field"] = self.field
            frame.stats["field_grids"] = len(self.field.grids)

    def _serves(self, made, key, progressive: bool) -> bool:
        """Whether a field `made` (key, version, converged) serves a frame asking for
        `key`: made for it, as things are now, and converged; or, in a viewport, made
        with the same bounces and at least the preset's density (the interactive
        preset of a moving view does not rebuild it)."""
        if not made or made[1] != self.version or not made[2]:
            return False
        if made[0] == key:
            return True
        return progressive and made[0][0] == key[0] and made[0][2:] == key[2:] and \
            RANK.index(made[0][1]) >= RANK.index(key[1])

    def _light_each_other(self, scene) -> bool:
        """surfaces_light_each_other, asked again only after the geometry, the lights or
        the materials changed (note): it compares every face with every point."""
        if self.lit_each_other is None:
            self.lit_each_other = surfaces_light_each_other(scene)
        return self.lit_each_other

    def note(self, changes):
        """Every sync's changes (Renderer.update: a frame's, or a sync outside one, as
        a host's or a tool's): the field is stale once what it holds changed."""
        c = changes
        moved = bool(c.meshes or c.dropped_meshes or c.instances or c.dropped_instances
                     or c.shapes or c.skeletons or c.lights)
        self.stale |= moved or bool(c.dome)
        self.touched |= bool(c.materials)
        if moved or c.points or c.materials:
            self.lit_each_other = None

    def _start(self, frame, view, key, updates: int):
        """A new Build for `key` in place of the one under way, if any."""
        self._drop_build()
        scene, preset = frame.scene, key[1]
        tracer = self.tracer(scene)
        lo, hi = self.bounds[1]
        made = grids(lo, hi, PROBES.get(preset, PROBES["medium"]), key[3])
        n, rays = sum(g.probes for g in made), RAYS.get(preset, RAYS["medium"])
        self.table = material_table(scene, tracer.materials, self.textures)
        materials = self.uploads.texture((self.table.shape[1], 1), 4, self.table, kind="field",
                                         dtype="f4")
        materials.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        diagonal = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
        steady = self._texture(atlas_size(n), False)
        fbo = self.ctx.framebuffer(color_attachments=[steady])
        fbo.clear(0.0, 0.0, 0.0, 0.0)    # no update's light yet
        fbo.release()
        self.build = Build(
            key=key, version=self.version, grids=made, n=n, rays=rays, updates=updates,
            # Per ray: radiance, the hit's normal, the field's bounces (irradiance_trace.comp).
            ray_tex=self.ctx.texture((3 * rays, n), 4, dtype="f4"), steady=steady,
            hits=HitTables(materials, self.uploads.buffer(instance_sides(scene, tracer),
                                                          kind="field"),
                           self.environment.prepare(scene.dome),
                           np.asarray(view.camera.forward, float),
                           1e-4 * max(diagonal, 1e-6), transmits(self.table)))
        self._key = key

    def _run(self, frame, budget) -> int:
        """Runs the build's next probes, update after update, within `budget` rays (None:
        to the end); returns the rays traced. A probe's update reads the field of the
        update before, complete: an update spread over frames gives what one frame's
        gives, and the last, the field a still makes."""
        b, scene = self.build, frame.scene
        trace = self.programs.get("irradiance_trace.comp", None,
                                  b.hits.defines(), compute=True)
        blend = self.programs.get("irradiance_blend.comp", None, [], compute=True)
        tracer = self.tracer(scene)
        traced = 0
        while b.k < b.updates:
            if b.target is None:
                b.target = self._free(b)
            count = b.n - b.probe
            if budget is not None:
                count = min(count, max((budget - traced) // b.rays, 0))
                if count == 0 and traced == 0:
                    count = 1            # a probe's rays above the budget: one a frame
            if count == 0:
                break
            R = rotation(b.k)
            read = b.prev if b.prev is not None else b.target   # the first reads no field
            b.hits.bind(trace, scene, read, tracer, self.lights, self.environment, b.k > 0)
            set_uniform(trace, "u_rotation", R)
            set_uniform(trace, "u_rays", b.rays)
            set_uniform(trace, "u_first_probe", b.probe)
            b.ray_tex.bind_to_image(0, read=False, write=True)
            trace.run(-(-b.rays // GROUP), count)
            self.ctx.memory_barrier(ALL_BARRIERS)
            read.bind(blend)
            b.ray_tex.use(UNITS["field_rays"])
            set_uniform(blend, "u_rotation", R)
            set_uniform(blend, "u_rays", b.rays)
            set_uniform(blend, "u_bounce", b.k > 0)
            set_uniform(blend, "u_first_probe", b.probe)
            set_uniform(blend, "u_near_cone", near_cone(b.rays * b.updates))
            set_uniform_array(blend, "u_max_distance", _rows(
                [1.5 * float(np.linalg.norm(g.step)) for g in b.grids], np.float32))
            b.target.irradiance.bind_to_image(0, read=False, write=True)
            b.target.distance.bind_to_image(1, read=False, write=True)
            b.target.probes.bind_to_image(2, read=False, write=True)
            b.target.planes.bind_to_image(3, read=False, write=True)
            b.steady.bind_to_image(4, read=True, write=True)
            blend.run(count, 1)
            self.ctx.memory_barrier(ALL_BARRIERS)
            traced += count * b.rays
            b.probe += count
            if b.probe == b.n:
                self._updated(frame, b)
        frame.stats["field_probes"] = b.n
        if b.k == b.updates:
            self._drop_build()
        return traced

    def _updated(self, frame, b):
        """Update k of build b is complete: the next reads it; frames show it when it is
        the last, or when what they showed is out of date (a viewport's edit shows its
        first bounce at once; a finer preset's field waits until it converged)."""
        before = b.prev
        b.prev, b.target, b.probe, b.k = b.target, None, 0, b.k + 1
        frame.count("field_updates")
        done = b.k == b.updates
        if done:
            self.fewer = before      # the gather's hits read it: the scene's bounces, no more
        if done or self.shown is None or self.shown[1] != b.version:
            self.field, self.shown = b.prev, (b.key, b.version, done)

    def _free(self, b):
        """A Field of build b's size that neither frames nor b read, from the pool or new,
        set to b's grids; Fields of other sizes that nothing reads are released."""
        size = atlas_size(b.n)
        busy = [f for f in (self.field, b.prev, self.fewer) if f is not None]
        unused = [f for f in self.pool if f.irradiance.size != size and
                  all(f is not x for x in busy)]
        for f in unused:
            f.release()
        self.pool = [f for f in self.pool if all(f is not x for x in unused)]
        spare = next((f for f in self.pool if f.irradiance.size == size and
                      all(f is not x for x in busy)), None)
        if spare is None:
            spare = Field(self._texture(size, True), self._texture(size, True),
                          self._texture((TILES_PER_LINE, size[1] // TILE), False),
                          self._texture((size[0], 2 * size[1]), False), b.grids)
            self.pool.append(spare)
        spare.grids = b.grids
        return spare

    def gather_tables(self):
        """The shown field's HitTables, for a final gather, where that field is complete
        and made for the scene as it is (else None: the field's light stays)."""
        done = self.shown is not None and self.shown[2] and self.shown[1] == self.version
        return self.hits if done else None

    def bind_hits(self, prog, frame):
        """Into `prog`: gather_tables, the light one bounce fewer, the shown field's walls."""
        self.hits.bind(prog, frame.scene, self.field, self.tracer(frame.scene), self.lights,
                       self.environment, self.fewer is not None, light=self.fewer)

    def _drop_build(self):
        if self.build is not None:
            b = self.build
            if b.k == b.updates:         # complete: its tables shade the final gather's hits
                self._release_hits()
                self.hits, b.hits = b.hits, None
            b.release()
            self.build = None

    def _release_hits(self):
        self.hits, old = None, self.hits
        if old is not None:
            old.release()

    def _texture(self, size, linear: bool):
        tex = self.ctx.texture(size, 4, dtype="f4")
        tex.filter = (self.ctx.LINEAR if linear else self.ctx.NEAREST,) * 2
        tex.repeat_x = tex.repeat_y = False
        return tex

    def release(self):
        self._drop_build()
        self._release_hits()
        for f in self.pool:
            f.release()
        self.pool, self.field, self.shown, self.fewer = [], None, None, None
