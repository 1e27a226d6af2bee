"""The irradiance field pass: the light that bounces off diffuse surfaces, as a grid of
probes over the scene's bounds (Majercik et al. 2019, "Dynamic Diffuse Global
Illumination with Ray-Traced Irradiance Fields"; 2021, "Scaling Probe-Based Real-Time
Dynamic GI for Production"). The ambient pass reads it per pixel (shaders/
irradiance_field.glsl) in place of the dome's diffuse light: the dome reaches surfaces
through the rays that escape, so the sky is counted once.

An update traces the preset's rays from every probe with the ray tracer
(engine/gpu/raytracer.py; shaders/irradiance_trace.comp), shades each hit with its
emission, the light table's lights (each seen by a shadow ray, so no shadow map is
needed at hits and none leaks), and its albedo times the field as it was (the bounces
so far), or the dome where a ray escapes; then writes each probe's octahedral maps of
irradiance, of the mean distance and its square, and of the planes of the nearest hits
about each direction (which say what a wall hides; shaders/irradiance_blend.comp),
moves probes out of walls and switches off those inside geometry. Each update adds
one bounce: a frame whose field is out of date runs the scene's diffuse bounces of
them from nothing, so a still and every frame of a sequence render it converged.

The field is kept while nothing it depends on changes (lights, geometry, materials,
the dome, the bounces, the preset; the grid covers the traced triangles' bounds): stats
field_updates counts the updates a frame ran.
Only on GL 4.3 (compute shaders) and only when the frame's bounces have a diffuse
bounce and the scene has surfaces and something that lights them; else the frame is
today's direct image, with no tracer.

A hit's albedo is its material's base colour times (1 - metallic), its emission the
material's emission colour, a texture map's mean colour where one is bound (the hit's
texel is not sampled), the constant where a pattern network feeds them.

reads: view   writes: field (the Field: bind it into a shading program)"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ....core.emission import SAMPLING
from ...emitters import closed, makes_lights, radiance
from ..framegraph import Pass
from ..programs import UNITS, set_uniform

TEXELS = 8                   # shaders/irradiance_field.glsl FIELD_TEXELS
TILE = TEXELS + 2
TILES_PER_LINE = 64
GROUP = 64                   # shaders/irradiance_trace.comp's local size
BIAS = 0.3                   # the read's self-shadowing bias, a share of the spacing
# Probes along the bounds' longest side, and rays a probe an update, by preset.
PROBES = {"low": 4, "medium": 6, "high": 8, "ultra": 10}
RAYS = {"low": 64, "medium": 128, "high": 192, "ultra": 256}
ALL_BARRIERS = 0xFFFFFFFF
SIDES_BINDING = 15           # shaders/irradiance_trace.comp FieldSides
FIELD_UNITS = ("field_irradiance", "field_distance", "field_probes", "field_materials",
               "field_rays", "field_planes")
# Probes sit off their cells' centres by this share of the spacing: walls often lie on
# the centres' planes (a room as wide as its bounds, split in even cells), and a probe
# on a wall sees both sides (its rays start in the wall's plane). Off it, the probe sees
# the wall and is moved from it (shaders/irradiance_blend.comp), on whichever side.
NUDGE = np.array([0.0371, 0.0253, 0.0419])
# The outermost probes lie this share of the spacing inside the bounds' faces: where the
# bounds are a room's walls, floor and ceiling (the closed box, a room's bounds), those
# probes see what the surfaces there see. Cell-centred probes, half a spacing in, left a
# floor lit by probes half a spacing above it, which miss the walls' lit lower parts
# (the emissive panel's floor got half its bounce) and the dim corners (the box's ceiling
# by the back wall 30% bright). Over the fifth of a spacing within which a probe is moved
# from a surface (shaders/irradiance_blend.comp), so a box's probes stay where they are.
INSET = 0.25


def would_bounce(frame) -> bool:
    """Whether `frame` asks for the bounce: a diffuse bounce, surfaces, and something
    that lights them (a lamp, the dome, an emissive material)."""
    scene = frame.scene
    if frame.options.bounces_for(scene).diffuse_bounces <= 0 or not scene.instances:
        return False
    return bool(scene.lights) or scene.dome is not None or \
        any(max(m.emissive) > 0.0 for m in scene.materials.values())


def grid(lo, hi, along_longest: int):
    """(first probe, spacing, counts) of a grid of probes over the box, `along_longest`
    of them along its longest side, the outermost INSET of a spacing inside its faces
    (a flat side: one layer, half a spacing off it)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    size = hi - lo
    spacing = max(float(size.max()), 1e-6) / (max(along_longest, 2) - 1 + 2 * INSET)
    cells = np.maximum(np.ceil(size / spacing - 2 * INSET - 1e-6), 1).astype(int)
    flat = size <= 0
    step = np.where(flat, spacing, size / (cells + 2 * INSET))
    counts = np.where(flat, 1, cells + 1)
    return lo + (np.where(flat, 0.5, INSET) + NUDGE) * step, step, counts


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


@dataclass
class Field:
    """The field's textures and grid, as a shading program reads them."""
    irradiance: object
    distance: object
    probes: object
    planes: object               # two hits' planes per distance texel
    lo: np.ndarray
    step: np.ndarray
    counts: np.ndarray

    def bind(self, prog):
        unbind_samplers(self.irradiance.ctx)
        self.irradiance.use(UNITS["field_irradiance"])
        self.distance.use(UNITS["field_distance"])
        self.probes.use(UNITS["field_probes"])
        self.planes.use(UNITS["field_planes"])
        set_uniform(prog, "field_lo", self.lo.astype(np.float64))
        set_uniform(prog, "field_step", self.step.astype(np.float64))
        set_uniform(prog, "field_counts", tuple(int(c) for c in self.counts))
        set_uniform(prog, "field_tiles", TILES_PER_LINE)
        set_uniform(prog, "field_bias", BIAS)

    def release(self):
        for tex in (self.irradiance, self.distance, self.probes, self.planes):
            tex.release()


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
        self.field = None            # the current Field
        self.spare = None            # the other one, which an update writes
        self._key = None             # what the field was made for
        self.stale = True            # what it holds changed since (note)
        self.touched = False         # materials changed since: their table is compared
        self.table = None            # the materials' albedo and emission it was built with
        self.seconds = 0.0           # the last build's CPU seconds (GPU work waited for)
        self.warnings = []           # without compute shaders: that the bounce is off

    def needed(self, frame) -> bool:
        if not would_bounce(frame):
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
        key = (bounces.diffuse_bounces, frame.preset.name, along)
        if self.field is not None and not self.stale and key == self._key and self.touched:
            # Only materials changed: the field holds their albedo and emission alone
            # (a pattern's parameters, a roughness, leave it as it is).
            tracer = self.tracer(frame.scene)
            self.stale = not np.array_equal(self._table(frame.scene, tracer.materials),
                                            self.table)
        self.touched = False
        if self.field is None or self.stale or key != self._key:
            self._build(frame, view, bounces.diffuse_bounces)
            self._key, self.stale = key, False
        board["field"] = self.field

    def note(self, changes):
        """Every sync's changes (Renderer.update: a frame's, or a sync outside one, as
        a host's or a tool's): the field is stale once what it holds changed."""
        c = changes
        self.stale |= bool(c.meshes or c.dropped_meshes or c.instances or c.dropped_instances
                           or c.shapes or c.skeletons or c.lights or c.dome)
        self.touched |= bool(c.materials)

    def _build(self, frame, view, updates: int):
        t0 = time.perf_counter()
        scene, preset = frame.scene, frame.preset.name
        tracer = self.tracer(scene)
        # Over what is traced, as its triangles lie (a skinned mesh's drawn box is padded
        # by its joints': F12's deformed copy and the file's rig would get two grids).
        lo, hi = tracer.bounds if tracer.bounds is not None else view.bounds
        first, step, counts = grid(lo, hi, PROBES.get(preset, PROBES["medium"]))
        n = int(np.prod(counts))
        rays = RAYS.get(preset, RAYS["medium"])
        self._make(first, step, counts)
        # Per ray: radiance, the hit's normal, the field's bounces (irradiance_trace.comp).
        ray_tex = self.ctx.texture((3 * rays, n), 4, dtype="f4")
        steady = self._cleared(self.field.irradiance.size)
        self.table = self._table(scene, tracer.materials)
        materials = self.uploads.texture((self.table.shape[1], 1), 4, self.table, kind="field",
                                         dtype="f4")
        materials.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        sides = self.uploads.buffer(self._instance_sides(scene, tracer), kind="field")
        env = self.environment.prepare(scene.dome)
        trace = self.programs.get("irradiance_trace.comp", None,
                                  ["HAS_DOME_MAP"] if env is not None else [], compute=True)
        blend = self.programs.get("irradiance_blend.comp", None, [], compute=True)
        diagonal = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
        try:
            for k in range(updates):
                R = rotation(k)
                tracer.bind()
                sides.bind_to_storage_buffer(SIDES_BINDING)
                self.field.bind(trace)
                materials.use(UNITS["field_materials"])
                if self.lights.texture is not None:
                    self.lights.texture.use(UNITS["u_lights"])
                self.environment.bind(trace, scene.dome, env)
                set_uniform(trace, "has_dome", scene.dome is not None)
                set_uniform(trace, "u_rotation", R)
                set_uniform(trace, "u_rays", rays)
                set_uniform(trace, "n_lights", len(self.lights.index))
                set_uniform(trace, "u_bounce", k > 0)
                set_uniform(trace, "u_epsilon", 1e-4 * max(diagonal, 1e-6))
                set_uniform(trace, "u_view_forward", np.asarray(view.camera.forward, float))
                ray_tex.bind_to_image(0, read=False, write=True)
                trace.run(-(-rays // GROUP), n)
                self.ctx.memory_barrier(ALL_BARRIERS)
                self.field.bind(blend)
                ray_tex.use(UNITS["field_rays"])
                set_uniform(blend, "u_rotation", R)
                set_uniform(blend, "u_rays", rays)
                set_uniform(blend, "u_max_distance", 1.5 * float(np.linalg.norm(step)))
                self.spare.irradiance.bind_to_image(0, read=False, write=True)
                self.spare.distance.bind_to_image(1, read=False, write=True)
                self.spare.probes.bind_to_image(2, read=False, write=True)
                self.spare.planes.bind_to_image(3, read=False, write=True)
                steady.bind_to_image(4, read=True, write=True)
                blend.run(n, 1)
                self.ctx.memory_barrier(ALL_BARRIERS)
                self.field, self.spare = self.spare, self.field
                frame.count("field_updates")
        finally:
            ray_tex.release()
            steady.release()
            materials.release()
            sides.release()
        frame.stats["field_probes"] = n
        frame.stats["field_rays"] = n * rays * updates
        self.ctx.finish()
        self.seconds = time.perf_counter() - t0
        frame.timings["field_build"] = self.seconds

    def _make(self, first, step, counts):
        """Both fields at this grid's size (their textures kept when it is the same),
        cleared on the GPU: probes on and in place, maps 0."""
        n = int(np.prod(counts))
        lines = -(-n // TILES_PER_LINE)
        size = (TILES_PER_LINE * TILE, lines * TILE)
        fields = [f for f in (self.field, self.spare) if f is not None]
        if len(fields) != 2 or fields[0].irradiance.size != size:
            for f in fields:
                f.release()
            fields = [Field(self._texture(size, True), self._texture(size, True),
                            self._texture((TILES_PER_LINE, lines), False),
                            self._texture((size[0], 2 * size[1]), False), first, step, counts)
                      for _ in range(2)]
        for f in fields:
            f.lo, f.step, f.counts = first, step, counts
            for tex, alpha in ((f.irradiance, 0.0), (f.distance, 0.0), (f.probes, 1.0),
                               (f.planes, 0.0)):
                self._clear(tex, alpha)
        self.field, self.spare = fields

    def _clear(self, tex, alpha=0.0):
        fbo = self.ctx.framebuffer(color_attachments=[tex])
        fbo.clear(0.0, 0.0, 0.0, alpha)
        fbo.release()

    def _cleared(self, size):
        tex = self._texture(size, False)
        self._clear(tex)
        return tex

    def _texture(self, size, linear: bool):
        tex = self.ctx.texture(size, 4, dtype="f4")
        f = self.ctx.LINEAR if linear else self.ctx.NEAREST
        tex.filter = (f, f)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def _table(self, scene, names) -> np.ndarray:
        """The tracer's materials: albedo, emission, two texels each."""
        table = np.zeros((1, 2 * max(len(names), 1), 4), np.float32)
        for i, name in enumerate(names):
            m = scene.materials.get(name)
            if m is None:
                table[0, 2 * i, :3] = 0.18
                continue
            base = m.maps.get("diffuseColor")
            base = m.diffuse if base is None else self.textures.mean(base)
            emission = m.maps.get("emissiveColor")
            emission = m.emissive if emission is None else self.textures.mean(emission)
            # Glass: its diffuse share (the field's rays stop at it; what it lets
            # through is not followed).
            table[0, 2 * i, :3] = np.asarray(base, np.float32) * (1.0 - m.metallic) * \
                (1.0 - m.transmission)
            table[0, 2 * i + 1, :3] = emission
            front, back = SAMPLING.get(m.emission_sampling, SAMPLING["auto"])
            table[0, 2 * i + 1, 3] = front + 2 * back
        return table

    def _instance_sides(self, scene, tracer) -> np.ndarray:
        """Per traced instance, the sides of its emitting faces that are lights of the
        light table (engine/emitters.py: 1 front, 2 back, 4 where its mesh's faces are
        made lights at all, 8 where the mesh is closed): a ray meeting them takes no
        emission there, which the lights bring per pixel; the other sides' emission (the
        inside of a closed emitter, a skinned one's, sampling None's) comes through the
        field, as Cycles finds it by BSDF sampling."""
        memo = {}
        flags = np.zeros(max(len(tracer.instances), 1), np.int32)
        for i, (path, _) in enumerate(tracer.instances):
            key = scene.instances[path].mesh_key
            if key not in memo:
                mesh = scene.meshes[key]
                emits = any(float(radiance(scene.materials[name]).max()) > 0.0
                            for name in mesh.materials if name in scene.materials)
                memo[key] = (4 * makes_lights(mesh) + 8 * closed(mesh)) if emits else 0
            flags[i] = memo[key]
        return flags

    def release(self):
        for f in (self.field, self.spare):
            if f is not None:
                f.release()
        self.field = self.spare = None
