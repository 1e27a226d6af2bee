"""Plain records of what gets drawn, kept by the USD side (engine/usd/) and drawn by
the GL side (engine/gpu/). No pxr, no GL: dataclasses and numpy arrays only, so each
side can be read, tested and replaced without the other.

Matrices are numpy float64 4x4 in column-vector convention (p' = M @ p), so a matrix
goes to GLSL as `M.T` bytes (column-major).

A Scene lives as long as its Session: records are keyed by prim path and replaced
when their prim changes; `Changes` says what one sync replaced, so the GL side
uploads only that."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .bounces import Bounces


# Floats a vertex of each per-vertex stream (MeshData.streams).
STREAM_WIDTHS = {"colors": 4, "generated": 3}


@dataclass
class TextureRef:
    path: str                      # resolved absolute path
    colorspace: str = "auto"       # sRGB | raw | auto
    wrap_s: str = "repeat"         # repeat | mirror | clamp | black
    wrap_t: str = "repeat"
    scale: tuple = (1.0, 1.0, 1.0, 1.0)
    bias: tuple = (0.0, 0.0, 0.0, 0.0)
    channel: str = "rgb"           # rgb | r | g | b | a
    filtertype: str = "linear"     # core/images.py FILTERTYPES (Blender's interpolation)
    # A UDIM image (a `<UDIM>` path): ((tile number, resolved path), ...) of the tiles
    # found, first tile first; `path` is the first tile's. () for a plain image.
    tiles: tuple = ()


@dataclass(frozen=True)
class PatternNode:
    """One node of a material's pattern graph (ND_lantern_<kind>, docs/materials.md).
    Types: "float", "vector", "color", "float[]", "color4[]", "asset" (an image's
    resolved path: bound as a texture, not a parameter)."""
    name: str
    kind: str
    settings: tuple                # ((name, str), ...) sorted: part of the graph's shape
    values: tuple                  # ((input, type, value), ...) sorted: per-material parameters
    links: tuple                   # ((input, type, source node, source output, source type), ...)


@dataclass(frozen=True)
class PatternGraph:
    """The node network feeding surface inputs: nodes sources first, outputs
    ((surface input, node, output, output type), ...)."""
    nodes: tuple
    outputs: tuple

    @property
    def shape(self) -> tuple:
        """Everything but the parameter values: equal shapes share one program."""
        return (tuple((n.kind, n.settings, tuple((i, t, len(v) if t.endswith("[]") else 0)
                                               for i, t, v in n.values), n.links)
                      for n in self.nodes), self.outputs)

    def feeds(self, target: str) -> bool:
        return any(o[0] == target for o in self.outputs)


@dataclass
class Material:
    name: str                      # the Material prim's path, or <default ...>
    diffuse: tuple = (0.18, 0.18, 0.18)
    metallic: float = 0.0
    roughness: float = 0.5
    ior: float = 1.5
    emissive: tuple = (0.0, 0.0, 0.0)
    opacity: float = 1.0
    opacity_threshold: float = 0.0
    clearcoat: float = 0.0         # the coat lobe's weight (white, F0 0.04)
    clearcoat_roughness: float = 0.01
    # input name ('diffuseColor', 'normal', ...) -> TextureRef
    maps: dict = field(default_factory=dict)
    uv_name: str | None = None     # primvar the material's reader asks for
    pass_index: int = 0            # lantern:passIndex: render pass IndexMA
    alpha_mode: str = ""           # lantern:alphaMode: "hashed" (Blender's Dithered), or ""
    # lantern:bumpMapCorrection: Cycles' correction of the shadow terminator of a normal
    # map (its default; Material > Settings > Bump Map Correction).
    bump_correction: bool = True
    # lantern:baseColorOcclusion: the base colour is multiplied by the frame's ambient
    # occlusion (an Ambient Occlusion node's Color on Base Color in Blender).
    base_occlusion: bool = False
    # lantern:sheenMode, sheenColor, sheenRoughness: a sheen lobe (core/sheen.py), or none.
    sheen_mode: str = ""
    sheen: tuple = (0.0, 0.0, 0.0)
    sheen_roughness: float = 0.5
    # lantern:transmission: the share of light the surface lets through as glass
    # (tinted by the base colour, refracted by the IOR, blurred by the roughness).
    transmission: float = 0.0
    # lantern:emissionSampling: the faces that light others (core/emission.py).
    emission_sampling: str = "auto"
    pattern: PatternGraph | None = None  # the mtlx network feeding surface inputs

    @property
    def has_sheen(self) -> bool:
        return bool(self.sheen_mode) and (max(self.sheen) > 0.0 or (
            self.pattern is not None and self.pattern.feeds("sheenColor")))

    @property
    def has_normal_map(self) -> bool:
        return "normal" in self.maps

    @property
    def udim_tiles(self) -> tuple:
        """The UDIM tile numbers its maps have, first tile first (() for none). The
        first tile draws with this record; each other tile with `for_tile`'s, bound to
        the triangles whose UVs lie in that tile (engine/usd/mesh.py)."""
        return tuple(sorted({t for ref in self.maps.values() for t, _ in ref.tiles}))

    def tile_name(self, tile: int) -> str:
        return f"{self.name}<UDIM {tile}>"

    def for_tile(self, tile: int) -> "Material":
        """This material with each UDIM map reading `tile`'s image (a map without that
        tile keeps its first tile's)."""
        maps = {name: replace(ref, path=dict(ref.tiles).get(tile, ref.path), tiles=())
                for name, ref in self.maps.items()}
        return replace(self, name=self.tile_name(tile), maps=maps)

    @property
    def color_attribute(self) -> str | None:
        """The colour primvar this material's network reads (its first attribute node)."""
        if self.pattern is None:
            return None
        return next((dict(n.settings).get("name") for n in self.pattern.nodes
                     if n.kind == "attribute"), None)

    @property
    def reads_generated(self) -> bool:
        """Whether the network reads Generated coordinates (a texture's unlinked Vector,
        a Texture Coordinate node's Generated)."""
        if self.pattern is None:
            return False
        sources = [link[3] for n in self.pattern.nodes for link in n.links]
        return "generated" in sources + [o[2] for o in self.pattern.outputs]

    @property
    def needs_tangents(self) -> bool:
        """A tangent-space normal map, as a texture or in a network."""
        return self.has_normal_map or (self.pattern is not None and
                                       any(n.kind == "normal_map" for n in self.pattern.nodes))

    @property
    def bends_normal(self) -> bool:
        """A normal map, or a network (Bump, Normal Map) feeding the normal."""
        return self.has_normal_map or (self.pattern is not None and self.pattern.feeds("normal"))

    @property
    def mesh_layout(self) -> tuple:
        """What this material asks of the meshes it is bound to (engine/usd/mesh.py):
        they are built again when it changes."""
        return (self.uv_name, self.needs_tangents, self.color_attribute, self.reads_generated,
                self.udim_tiles)

    @property
    def needs_smooth_normal(self) -> bool:
        """Whether shading needs the normal before the normal map as well as after it
        (the bump map correction, shaders/lib.glsl bump_shadowing)."""
        return self.bump_correction and self.bends_normal

    @property
    def alpha(self) -> str:
        """How the material's opacity is drawn (docs/stage_contract.md, "Material"):
          opaque  opacity 1, no opacity map
          clip    a cut-out (opacityThreshold > 0): the G-buffer and the shadow casters
                  discard below the threshold
          blend   see-through (an opacity below 1 or an opacity map, no threshold):
                  Blender's Blended and Dithered (hashed) alike, since Cycles renders
                  both as the same continuous transparency. Its opaque texels (alpha >=
                  OPAQUE_ALPHA) go in the G-buffer like a cut-out's; the rest is drawn
                  by the transparency pass, blended, and casts transparent shadows.
          glass   transmissive (lantern:transmission > 0): drawn by the glass pass
                  (refracted), not in the G-buffer; its shadow lets light through."""
        if self.transmission > 0.0:
            return "glass"
        if self.opacity_threshold > 0.0:
            return "clip"
        if "opacity" in self.maps or self.opacity < 1.0 or self.opacity_varies:
            return "blend"
        return "opaque"

    @property
    def gbuffer_threshold(self) -> float | None:
        """The G-buffer's alpha test: discard below it (0: none); None: not drawn there
        at all (a blend material with no opacity map has no opaque texel)."""
        alpha = self.alpha
        if alpha == "clip":
            return self.opacity_threshold
        if alpha == "blend":
            return OPAQUE_ALPHA if "opacity" in self.maps or self.opacity_varies else None
        if alpha == "glass":
            return None
        return 0.0

    @property
    def opacity_varies(self) -> bool:
        return self.pattern is not None and self.pattern.feeds("opacity")


# At or above this alpha a blended texel is opaque (an 8-bit 255 and its filtered
# neighbours): drawn in the G-buffer, where depth orders it exactly.
OPAQUE_ALPHA = 1.0 - 1.0 / 1024.0


@dataclass
class PatchData:
    """A subdivision surface for the GPU's tessellation stages: one bicubic Bezier
    patch per quad of its cage refined `levels` times (engine/bezier_patches.py),
    sorted by material. The tessellation pass writes the triangles into the mesh's
    vertices each view, at most `cap` segments per patch edge."""
    control: np.ndarray            # (P, 16, 3) float32 Bezier control points, B[v][u]
    uv: np.ndarray                 # (P, 16, 2) float32 Bezier control points of the UVs
    ranges: list                   # [(material index, first patch, patch count)]
    levels: int                    # CPU refinements before the patches
    cap: int                       # most segments per patch edge
    # A skinned cage: each control point as a weighted sum of the cage's points, CSR
    # (indptr, point indices, weights), for the GPU to make the patches after each pose.
    stencils: tuple | None = None

    @property
    def max_vertices(self) -> int:
        """Triangle corners the patches make at most (2 cap^2 triangles each)."""
        return len(self.control) * 6 * self.cap * self.cap


@dataclass
class MeshData:
    """Indexed triangles sorted by material. vertices: (V, 12) float32 = position 3,
    normal 3, uv 2, tangent 4 (w = handedness); indices: (3T,) uint32 into vertices.
    A vertex is one face corner, or one point when every attribute is per point."""
    key: tuple
    vertices: np.ndarray
    indices: np.ndarray
    ranges: list                   # [(material index, first index, index count)]
    materials: list                # [Material name], indexed by ranges: Scene.materials keys
    double_sided: bool = True
    backface_culling: bool = False  # lantern:backfaceCulling: culling was asked for
    point_of_vertex: np.ndarray | None = None  # (V,) int32: vertex -> mesh point
    skin: "SkinData | None" = None            # UsdSkel binding
    # No normals authored: they are the surface's own (area-weighted per point), and a
    # skinned or blend-shaped mesh has them computed again from its deformed surface.
    surface_normals: bool = False
    bounds: tuple | None = None    # (lo, hi) float64 of the vertex positions
    # Per-vertex data bound networks read, (V, STREAM_WIDTHS[name]) float32 each
    # (engine/gpu/stores.py STREAMS): "colors", an attribute (rgb and alpha);
    # "generated", Blender's Generated coordinates (the rest points in their bounding
    # box, as its auto texture space).
    streams: dict = field(default_factory=dict)
    # A subdivision surface tessellated on the GPU: `vertices` and `indices` are then
    # empty and `ranges` are the patches' (PatchData.ranges); the triangles are made
    # each view (engine/gpu/passes/tessellation.py).
    patches: "PatchData | None" = None

    def __post_init__(self):
        if self.bounds is None and len(self.vertices):
            p = self.vertices[:, :3].astype(np.float64)
            self.bounds = (p.min(axis=0), p.max(axis=0))

    @property
    def index_count(self) -> int:
        return int(len(self.indices))


@dataclass
class SkinData:
    """A mesh's static UsdSkel binding, per vertex of its MeshData. Joint indices are
    in the skeleton's order (the binding's joint mapper already applied); index
    n_joints is an identity joint for mesh joints the skeleton lacks."""
    skel_key: str = ""
    n_points: int = 0
    joints: np.ndarray | None = None       # (V, 4g) int32, or None: blend shapes only
    weights: np.ndarray | None = None      # (V, 4g) float32
    # More than 8 influences: per point, g texel pairs (joints, weights), read by in_point.
    point_influences: np.ndarray | None = None
    geom_bind: np.ndarray = field(default_factory=lambda: np.eye(4))
    method: str = "lbs"                    # lbs | dqs
    # Blend shapes: sub-shape i's point offsets are block shape_blocks[i][0] of
    # shape_offsets (n_points texels each), its normal offsets block [1] (-1: none).
    shape_offsets: np.ndarray | None = None  # (n_blocks * n_points, 3) float32
    shape_blocks: list = field(default_factory=list)
    shape_max: np.ndarray | None = None    # (n_sub,) largest offset length, for bounds
    joint_radius: np.ndarray | None = None  # (n_joints+1,) bound points' max distance
    joint_centers: np.ndarray | None = None  # (n_joints+1, 3) bind-pose joint positions
    joint_used: np.ndarray | None = None    # joints with a non-zero weight somewhere

    @property
    def has_joints(self) -> bool:
        return self.joints is not None


@dataclass
class Instance:
    """One Mesh prim drawn: its MeshData (shared by prims with the same data) where.
    A PointInstancer's instances of one prototype mesh are one Instance too, keyed
    `<instancer path>{<mesh path>}` (`+`/`-` for mirroring ones), drawn by GPU
    instancing: `worlds` holds every instance's world matrix and `world` is unused."""
    path: str
    mesh_key: tuple
    world: np.ndarray              # 4x4 (skinned with joints: the skeleton's local-to-world)
    # This frame's blend shapes: [(sub-shape index, weight)], zero weights left out.
    shapes: list = field(default_factory=list)
    worlds: np.ndarray | None = None   # (n, 4, 4): instanced, one world matrix per instance
    pass_index: int = 0            # lantern:passIndex of it or an ancestor: IndexOB
    asset: str = ""                # the asset it belongs to (CryptoAsset): usd/read.py asset_path


@dataclass
class PointCloud:
    """A UsdGeom.Points prim: spheres of the given radii at its points (its own space,
    placed by `world`), lit like meshes with its material's constants, or per-point
    displayColor. With `segments`, curves as round tubes: each pair of points joined
    by the spheres swept between them (radius varying linearly), coloured by the
    pair's first point."""
    path: str
    points: np.ndarray             # (n, 3) float64
    radii: np.ndarray              # (n,)
    colours: np.ndarray | None     # (n, 3) displayColor, or None: the material's
    material: str                  # Scene.materials key
    world: np.ndarray = field(default_factory=lambda: np.eye(4))
    asset: str = ""                # as Instance.asset
    segments: np.ndarray | None = None   # (s, 2) point index pairs: tubes, not spheres

    @property
    def bounds(self):
        r = self.radii[:, None]
        return (self.points - r).min(axis=0), (self.points + r).max(axis=0)


@dataclass
class SkelPose:
    """A skeleton at one time: UsdSkel skinning transforms (skeleton space, column-
    vector), plus the identity joint at index n_joints."""
    xforms: np.ndarray             # (n_joints + 1, 4, 4)
    dqs: bool = False              # a bound mesh skins with dual quaternions


@dataclass
class Light:
    """kind: a core.lights kind. `color` is already radiometric: radiant intensity I
    [W/sr] for point/spot, radiance L [W/(sr m2)] for rect/disk, irradiance E [W/m2]
    for sun. A headlight shines along the camera's view, wherever it looks."""
    kind: str
    name: str
    color: np.ndarray
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))  # emission dir
    x_axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    y_axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    radius: float = 0.0
    soft_falloff: bool = True
    cone_angle: float = 180.0      # half angle, degrees; >= 90 means no cone
    cone_softness: float = 0.0
    width: float = 0.0
    height: float = 0.0
    angle: float = 0.0
    diffuse: float = 1.0
    specular: float = 1.0
    shadow: bool = True
    shadow_resolution: int = 0     # lantern:shadowResolution; 0 = the preset's
    headlight: bool = False
    # POLYGON (engine/emitters.py): polygons (wound to face their light), radiances, faces
    polygons: tuple = ()
    polygon_colors: np.ndarray | None = None
    two_sided: np.ndarray | None = None
    emitter: tuple = ()            # POLYGON: (instance path, instance) that emits it

    @property
    def direction(self) -> np.ndarray:
        """The unit emission direction."""
        return self.axis / max(float(np.linalg.norm(self.axis)), 1e-30)

    @property
    def cos_half(self) -> float:
        """cos of the spot cone's half angle (-1: no cone)."""
        return math.cos(math.radians(min(self.cone_angle, 180.0)))


@dataclass
class Dome:
    name: str
    radiance: np.ndarray           # uniform colour x intensity (also the map's multiplier)
    sh: np.ndarray                 # (9, 3) irradiance harmonics of the uniform colour (lighting.uniform_sh)
    texture: str | None = None     # lat-long image shown as the background
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))  # dome local -> world
    ao_distance: float | None = None  # lantern:aoDistance (Blender's AO distance); None: unset


@dataclass
class Camera:
    view: np.ndarray
    proj: np.ndarray
    position: np.ndarray
    forward: np.ndarray
    near: float
    far: float
    ortho: bool = False
    name: str = ""


@dataclass
class Scene:
    """Everything a stage draws, keyed by prim path, in the stage's traversal order."""
    meshes: dict = field(default_factory=dict)     # key -> MeshData
    instances: dict = field(default_factory=dict)  # mesh prim path -> Instance
    points: dict = field(default_factory=dict)     # Points prim path -> PointCloud
    materials: dict = field(default_factory=dict)  # material name -> Material
    lights: dict = field(default_factory=dict)     # light prim path -> Light
    dome: Dome | None = None
    skeletons: dict = field(default_factory=dict)  # skel key -> SkelPose
    warnings: dict = field(default_factory=dict)   # prim path -> [message]
    meters_per_unit: float = 1.0
    up_axis: str = "Z"
    # /Render/Settings' bounces (docs/stage_contract.md); None: the stage names none,
    # and a render lights it directly, as Storm does.
    bounces: Bounces | None = None

    def warning_list(self) -> list:
        return [w for ws in self.warnings.values() for w in ws]


@dataclass
class Changes:
    """What one sync of the stage replaced, for the GL side to upload: only that."""
    meshes: set = field(default_factory=set)            # mesh keys built or rebuilt
    dropped_meshes: set = field(default_factory=set)
    instances: set = field(default_factory=set)         # paths added, moved or re-meshed
    dropped_instances: set = field(default_factory=set)
    points: set = field(default_factory=set)            # Points paths added, changed or dropped
    shapes: set = field(default_factory=set)            # paths with new blend-shape weights
    skeletons: set = field(default_factory=set)         # skel keys posed anew
    materials: set = field(default_factory=set)         # material names re-read
    lights: set = field(default_factory=set)            # light paths added, changed or dropped
    cameras: set = field(default_factory=set)           # camera paths added, edited or dropped
    dome: bool = False
    prims_read: int = 0

    def __bool__(self):
        return bool(self.meshes or self.dropped_meshes or self.instances or
                    self.dropped_instances or self.points or self.shapes or self.skeletons or
                    self.materials or self.lights or self.cameras or self.dome)
