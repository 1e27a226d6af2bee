"""The G-buffer pass: every visible object's material into the deferred targets.

Objects outside the view's frustum are culled; the rest draw as state batches
(material variant, culling, winding), front to back within a batch (see
engine/gpu/commands.py for the GL 4.3 and GL 3.3 paths). A material's shader variant
has only the maps it uses (feature bits, as Filament's); its constants are uniforms
and its images stay on the GPU for the session. Blended materials (Material.alpha)
draw here only their opaque texels, and not at all without an opacity map: the
transparency pass draws the rest.

reads: skinned (posed geometry), tessellated (optional), view
writes: g_base (base colour + alpha), g_normal (world normal, clearcoat roughness),
        g_mat (metallic, roughness, dielectric F0, clearcoat), g_emit (emission), all
        RGBA16F; g_depth (32-bit
        float, reversed: cleared to 0, tested GREATER; engine/view.py); g_smooth (the
        normal before the normal map, RGBA16F) only in frames with a normal-mapped
        material, for Cycles' bump map correction (shaders/lib.glsl bump_shadowing);
        g_sheen (RGBA16F: the sheen colour, its roughness + 2 x its mode's number in
        core/sheen.MODES) only in frames with a sheen (shaders/lib.glsl apply_sheen)
A material with a pattern graph (engine/gpu/pattern.py) draws with its shape's
generated variant and its parameters (stats: pattern_bytes).
render passes: IndexOB, IndexMA into g_index (RGBA32F: the object's and material's
        pass indices, 1 + the object's id, the material's Cryptomatte id), only when
        asked for, or when Cryptomatte is (a shader variant with one more output)
edge samples: edge_depth (g_depth at four places a texel: multisampled, 32-bit float),
        in supersampled frames whose preset has edge_samples: the same draws again,
        depth only (DEPTH_ONLY: the alpha test and nothing else). The supersample
        reduction places geometric edges by it (passes/antialias.py).
coverage: a samples query around the draws (read when the frame is finished, so no
        wait: stats fragments_drawn), which says when nothing of the stage is on screen"""
from __future__ import annotations

from collections import Counter

from ....core.cryptomatte import name_id
from ....core.images import FILTERTYPES
from ....core.passes import wants_ids
from ....core.sheen import MODES as SHEEN_MODES
from ..framegraph import Pass
from ..points import set_camera_facing
from ..readback import SLOTS
from ..pattern import material_variant, pattern_images, set_parameters
from ..programs import UNITS, set_uniform
from .antialias import BLACKMAN_HARRIS, FILTER_WIDTH

# Material input -> shader names and variant define.
MAP_SLOTS = [("diffuseColor", "diffuse", "HAS_DIFFUSE_MAP"), ("metallic", "metallic", "HAS_METALLIC_MAP"),
             ("roughness", "roughness", "HAS_ROUGHNESS_MAP"), ("emissiveColor", "emissive", "HAS_EMISSIVE_MAP"),
             ("opacity", "opacity", "HAS_OPACITY_MAP"), ("normal", "normal", "HAS_NORMAL_MAP")]
WRAP = {"repeat": 0, "mirror": 1, "clamp": 2, "black": 3}
# The interpolations beside Linear whose code a program compiles in where one of its
# images has them (material.glsl interpolated): llvmpipe runs every branch of a
# shader, masked, and a Linear image's lookups took 1.5x as long with the other two in.
FILTER_DEFINES = {"closest": "FILTER_CLOSEST", "cubic": "FILTER_CUBIC", "smart": "FILTER_CUBIC"}
CHANNEL = {"rgb": -1, "r": 0, "g": 1, "b": 2, "a": 3}
TARGETS = ("g_base", "g_normal", "g_mat", "g_emit", "g_depth")
# The optional targets, in this order after the first four, and the define of the
# shader output that writes each (gbuffer.frag, points.frag).
OUTPUT_DEFINES = {"g_smooth": "WRITE_SMOOTH_NORMAL", "g_sheen": "WRITE_SHEEN"}


class GBufferPass(Pass):
    name = "gbuffer"
    reads = ("skinned", "view")
    optional = ("tessellated",)
    writes = TARGETS + ("coverage",)
    writes_optional = ("g_smooth", "g_sheen", "g_index", "edge_depth")
    aovs = {"IndexOB": ("g_index", 0), "IndexMA": ("g_index", 1)}

    def __init__(self, ctx, pool, programs, geometry, textures, depth):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.geometry, self.textures, self.depth = geometry, textures, depth
        # One coverage query per frame that can be in flight (ModernGL's queries
        # live as long as the context): a frame's is read before it comes round again.
        self._queries = [ctx.query(samples=True) for _ in range(SLOTS + 1)]
        self._next_query = 0

    def wanted(self, frame):
        # The normal before the normal map, for Cycles' bump map correction (lib.glsl
        # bump_shadowing), only in frames that draw a normal-mapped material.
        # A sheen, only in frames that draw one.
        # The ids, for Cryptomatte (passes/cryptomatte.py).
        # The edge samples, in supersampled frames that ask for them, where the GL
        # has four samples a texel.
        materials = frame.scene.materials.values()
        edges = frame.supersample > 1 and frame.preset.edge_samples and \
            self.ctx.max_samples >= 4
        return (("g_smooth",) if any(m.needs_smooth_normal for m in materials) else ()) + \
            (("g_sheen",) if any(m.has_sheen for m in materials) else ()) + \
            (("g_index",) if wants_ids(frame.aovs) else ()) + \
            (("edge_depth",) if edges else ())

    def program_args(self, mat, defines):
        """ProgramCache.get's arguments for `mat`'s variant, with these defines (the
        optional outputs': OUTPUT_DEFINES' values and WRITE_INDEX; or DEPTH_ONLY)."""
        defines = map_defines(mat) + self.geometry.commands.object_defines() + list(defines)
        return "gbuffer.vert", "gbuffer.frag", defines, (), False, material_variant(mat)

    def frame_program_args(self, frame, mat):
        """program_args as this frame will draw `mat` (its targets: wanted, aov_targets)."""
        wanted = self.wanted(frame)
        return self.program_args(mat, output_defines(wanted + self.aov_targets(frame)))

    def execute(self, frame, board):
        ctx, view = self.ctx, board["view"]
        colors = [board[n] for n in TARGETS[:4] + tuple(OUTPUT_DEFINES) + ("g_index",)
                  if n in board]
        outputs = output_defines(board)
        cam = view.camera
        batches, culled = self.geometry.commands.view_batches(
            view.boxes, cam.position, cam.forward, view.outside)
        frame.count("culled", culled)
        self.geometry.bind_objects(UNITS["u_objects"])
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = ">"
        self.depth.far_clip(True)
        ctx.disable(ctx.BLEND)
        coverage = board["coverage"] = self._queries[self._next_query]
        self._next_query = (self._next_query + 1) % len(self._queries)
        coverage.mglo.begin()
        drawn = self._draw(frame, view, batches,
                           self.pool.framebuffer(colors, depth=board["g_depth"]), outputs)
        coverage.mglo.end()
        for name, n in drawn.items():
            frame.count(name, n)
        if "edge_depth" in board:
            drawn = self._draw(frame, view, batches,
                               self.pool.framebuffer(depth=board["edge_depth"]), ["DEPTH_ONLY"])
            frame.count("edge_draw_calls", drawn["draw_calls"])
        ctx.disable(ctx.DEPTH_TEST)
        self.depth.far_clip(False)

    def _draw(self, frame, view, batches, fbo, defines) -> dict:
        """The frame's batches and point clouds into `fbo`, cleared first, with these
        variant defines. Returns the stats of what it drew (draw_calls,
        instances_drawn, points_drawn, pattern_bytes), each only where it drew any."""
        ctx = self.ctx
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)
        ctx.cull_face = "back"
        materials = frame.scene.materials
        drawn = Counter()
        for batch in batches:
            mat = materials[batch.material]
            threshold = mat.gbuffer_threshold
            if mat.alpha == "glass" and not frame.glass_refracts:
                threshold = 0.0            # light does not go through: opaque
            if threshold is None:
                continue                   # wholly see-through: the transparency pass's
            prog = self.programs.get(*self.program_args(mat, defines))
            set_uniform(prog, "view_proj", view.view_proj)
            set_uniform(prog, "u_far", view.far_clip)
            view.set_origin(prog)
            drawn["pattern_bytes"] += set_material(prog, mat, self.textures, threshold,
                                                   frame.supersample == 1)
            # A mirroring transform turns counter-clockwise triangles clockwise.
            ctx.front_face = "cw" if batch.mirrored else "ccw"
            if batch.cull:
                ctx.enable(ctx.CULL_FACE)
            else:
                ctx.disable(ctx.CULL_FACE)
            self.geometry.commands.draw_batch(batch, prog)
            drawn["draw_calls"] += batch.count
            drawn["instances_drawn"] += batch.instances
        ctx.front_face = "ccw"
        ctx.disable(ctx.CULL_FACE)
        if self.geometry.points.clouds:
            draws, points = self._points(frame, view, materials, defines)
            drawn["draw_calls"] += draws
            drawn["points_drawn"] += points
        return drawn

    def _points(self, frame, view, materials, defines):
        """Points prims: spheres facing the camera (points.vert), depth-tested with
        the meshes. Returns (draw calls, points drawn)."""
        def setup(prog, cloud):
            set_camera_facing(prog, view)
            mat = materials[cloud.material]
            set_material(prog, mat, self.textures, mat.opacity_threshold, frame.supersample == 1)

        return self.geometry.points.draw(
            self.programs, "gbuffer", setup, lambda lo, hi: not view.outside(lo[None], hi[None])[0],
            defines)


def output_defines(targets) -> list:
    """The defines of the optional outputs among `targets` (names), in their order."""
    return [d for n, d in OUTPUT_DEFINES.items() if n in targets] + \
        (["WRITE_INDEX"] if "g_index" in targets else [])


def set_material(prog, mat, textures, threshold, pixel_filter=False):
    """A material's uniforms and maps (shaders/material.glsl); `threshold`: the alpha
    test, discarding below it (0: none); `pixel_filter`: texture lookups filter with
    Cycles' pixel filter (an image not supersampled: they are its only filter), else
    over their fragment only. Returns the pattern parameters' bytes."""
    set_uniform(prog, "u_max_anisotropy", float(textures.anisotropy))
    set_uniform(prog, "u_pixel_filter", BLACKMAN_HARRIS)
    set_uniform(prog, "u_pixel_filter_reach", FILTER_WIDTH if pixel_filter else 0.0)
    set_uniform(prog, "u_diffuse", mat.diffuse)
    set_uniform(prog, "u_metallic", mat.metallic)
    set_uniform(prog, "u_roughness", mat.roughness)
    set_uniform(prog, "u_ior", mat.ior)
    set_uniform(prog, "u_emissive", mat.emissive)
    set_uniform(prog, "u_opacity", mat.opacity)
    set_uniform(prog, "u_transmission", mat.transmission)
    set_uniform(prog, "u_opacity_threshold", threshold)
    set_uniform(prog, "u_clearcoat", mat.clearcoat)
    set_uniform(prog, "u_clearcoat_roughness", mat.clearcoat_roughness)
    set_uniform(prog, "u_base_occlusion", 1.0 if mat.base_occlusion else 0.0)
    set_uniform(prog, "u_sheen", sheen_texel(mat))
    set_uniform(prog, "u_material_index", float(mat.pass_index))
    set_uniform(prog, "u_material_id", name_id(mat.name))
    set_uniform(prog, "u_bump_correction", bool(mat.bump_correction))
    pattern_bytes = set_parameters(prog, mat)
    for name, short, _ in MAP_SLOTS:
        ref = mat.maps.get(name)
        if ref is not None:
            _bind_map(prog, short, ref, textures)
    for k, ref in enumerate(pattern_images(mat)):
        _bind_map(prog, f"pattern{k}", ref, textures)
    return pattern_bytes


def sheen_texel(mat) -> tuple:
    """What g_sheen holds for `mat` (its network may replace the colour and roughness:
    material.glsl): its sheen colour, and its roughness + 2 x its mode's number; alpha
    -1 for none."""
    if not mat.has_sheen:
        return (0.0, 0.0, 0.0, -1.0)
    return (*mat.sheen, min(max(mat.sheen_roughness, 0.0), 1.0) +
            2.0 * SHEEN_MODES.index(mat.sheen_mode))


def _bind_map(prog, short, ref, textures):
    """Texture t_<short> and its Map m_<short> (shaders/material.glsl sample_map)."""
    unit = UNITS[f"t_{short}"]
    tex, decode = textures.get(ref.path, ref.colorspace)
    tex.use(unit)
    set_uniform(prog, f"m_{short}.srgb", bool(decode))
    textures.sampler(ref.wrap_s, ref.wrap_t, decode or ref.filtertype != "linear").use(unit)
    set_uniform(prog, f"m_{short}.wrap", (WRAP.get(ref.wrap_s, 0), WRAP.get(ref.wrap_t, 0)))
    set_uniform(prog, f"m_{short}.scale", tuple(ref.scale))
    set_uniform(prog, f"m_{short}.bias", tuple(ref.bias))
    set_uniform(prog, f"m_{short}.channel", CHANNEL.get(ref.channel, -1))
    set_uniform(prog, f"m_{short}.filtertype", FILTERTYPES.index(ref.filtertype))


def filter_defines(refs) -> list:
    """The defines of the interpolations these images (TextureRefs) need beside
    Linear (FILTER_DEFINES)."""
    return sorted({FILTER_DEFINES[r.filtertype] for r in refs if r.filtertype in FILTER_DEFINES})


def map_defines(mat) -> list:
    """The variant of a program including shaders/material.glsl for this material (and
    PATTERN_NORMAL: a network bends the normal, which needs the position;
    COLOR_ATTRIBUTE, PATTERN_GENERATED: a network reads the mesh's colour attribute,
    its Generated coordinates)."""
    pattern_normal = mat.pattern is not None and mat.pattern.feeds("normal")
    return [flag for name, _, flag in MAP_SLOTS if name in mat.maps] + \
        filter_defines([*mat.maps.values(), *pattern_images(mat)]) + \
        (["PATTERN_NORMAL"] if pattern_normal else []) + \
        (["COLOR_ATTRIBUTE"] if mat.color_attribute is not None else []) + \
        (["PATTERN_GENERATED"] if mat.reads_generated else [])
