"""Plain records between gathering (bpy) and writing (pxr).

Nothing here imports bpy or pxr, so the writers can be tested and reasoned about
without Blender, and the gatherers without USD.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class StageSettings:
    fps: float = 24.0
    frame_start: int = 1
    frame_end: int = 250
    meters_per_unit: float = 1.0
    up_axis: str = "Z"
    resolution: tuple[int, int] = (1920, 1080)
    pixel_aspect: float = 1.0
    camera: str | None = None  # key of the active camera's ObjectRecord
    # Colour management (Render Properties > Color Management), for display images.
    view_transform: str = "Standard"
    look: str | None = None     # Blender's look identifier, e.g. "AgX - Punchy"
    exposure: float = 0.0       # stops
    # Cycles' Light Paths: Max Bounces, Diffuse and Glossy (Cycles' defaults).
    max_bounces: int = 12
    diffuse_bounces: int = 4
    glossy_bounces: int = 4
    # The view layer's render passes (core/passes.py names): with any, a RenderProduct
    # of them is written, named `output` (Blender's output path as a productName).
    view_layer: str = "ViewLayer"
    render_passes: tuple = ()
    output: str = ""


@dataclass
class TextureRecord:
    file: str                  # absolute path of an image on disk
    uv: str | None             # UV map name; None: the mesh's render-active map
    wrap: str = "repeat"       # repeat / mirror / clamp / black
    color_space: str = "sRGB"  # sRGB / raw
    scale: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    bias: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    filtertype: str = "linear"  # core/images.py FILTERTYPES (Blender's interpolation)


@dataclass
class TexInput:
    """A material input read from a texture output: 'rgb' or one of 'r','g','b','a'."""
    texture: TextureRecord
    channel: str = "rgb"


@dataclass
class MaterialRecord:
    key: str    # Blender's unique name (name_full)
    name: str
    # UsdPreviewSurface input name -> float, 3-tuple or TexInput
    inputs: dict = field(default_factory=dict)
    backface_culling: bool = False
    pass_index: int = 0         # Blender's material pass index (render pass IndexMA)
    alpha_mode: str = ""        # "hashed" (Dithered and see-through), else "" (contract)
    bump_correction: bool = True  # Cycles' Bump Map Correction (contract: Material)
    emission_sampling: str = "auto"  # Cycles' Emission Sampling (core/emission.py token)
    # The base colour comes through an Ambient Occlusion node's Color: times the
    # renderer's ambient occlusion (contract: Material, lantern:baseColorOcclusion).
    base_occlusion: bool = False
    sheen: SheenRecord | None = None   # a sheen lobe (contract: Sheen), if any
    transmission: float = 0.0   # the share that goes through, as glass (contract: Glass)
    graph: PatternGraph | None = None  # the node network feeding surface inputs, if any


@dataclass
class SheenRecord:
    """A sheen lobe: the Principled BSDF's Sheen (weight x tint) or a Sheen BSDF added
    to the surface, as core/sheen.py names its modes."""
    mode: str                 # core/sheen.MODES
    color: tuple              # linear RGB: Sheen Weight x Sheen Tint, or the BSDF's Color
    roughness: float


@dataclass
class PatternNode:
    """One node of a material's pattern graph (docs/materials.md lists the kinds).
    Types are "float", "vector" or "color" (3 floats; a colour's alpha is dropped)."""
    name: str                 # prim name inside the graph
    kind: str                 # Lantern node kind; written as info:id ND_lantern_<kind>
    settings: dict = field(default_factory=dict)  # name -> str: the graph's shape
    values: dict = field(default_factory=dict)    # input -> (type, float | tuple | list)
    links: dict = field(default_factory=dict)     # input -> (type, node name, output)
    outputs: dict = field(default_factory=dict)   # output -> type


@dataclass
class PatternGraph:
    nodes: list = field(default_factory=list)     # PatternNode, sources before users
    outputs: dict = field(default_factory=dict)   # surface input -> (node name, output)


@dataclass
class MeshRecord:
    key: str
    name: str
    points: np.ndarray            # (N, 3) float32, object space
    face_counts: np.ndarray       # (F,) int32
    face_indices: np.ndarray      # (C,) int32
    normals: np.ndarray           # (N, 3) vertex or (C, 3) faceVarying
    normals_interpolation: str    # "vertex" / "faceVarying"
    uvs: dict = field(default_factory=dict)  # name -> (C, 2) float32, faceVarying
    active_uv: str | None = None  # render-active UV map name
    material_indices: np.ndarray | None = None  # (F,) int32 slot index per face
    # MikkTSpace (C, 4): tangent xyz, bitangent sign; only with a normal-mapped material.
    tangents: np.ndarray | None = None
    # Colour attributes a bound material's network reads: primvar name -> (C, 3) float32,
    # scene linear, per corner ("displayColor": the render colour attribute).
    colors: dict = field(default_factory=dict)
    skin: SkinRecord | None = None            # points are the rest mesh, skinned by a rig
    point_samples: PointSamples | None = None  # baked deformation, one sample per frame
    subdivision: SubdivisionRecord | None = None  # points are a Catmull-Clark cage


@dataclass
class SubdivisionRecord:
    """A cage's Catmull-Clark rules, as UsdGeom.Mesh has them."""
    render_level: int
    viewport_level: int
    crease_indices: np.ndarray      # (2E,) int32, vertex pairs
    crease_lengths: np.ndarray      # (E,) int32, all 2
    crease_sharpnesses: np.ndarray  # (E,) float32, OpenSubdiv sharpness (10: infinite)
    corner_indices: np.ndarray      # (K,) int32
    corner_sharpnesses: np.ndarray  # (K,) float32
    interpolate_boundary: str       # "edgeOnly" / "edgeAndCorner"
    face_varying_linear_interpolation: str
    limit_surface: bool = True      # Use Limit Surface: the level's points on the limit


@dataclass
class PointSamples:
    """Baked points (and normals, same interpolation as the record's) per time code."""
    times: list                   # frames
    points: list                  # per time: (N, 3) float32
    normals: list                 # per time: (N, 3) or (C, 3) float32


@dataclass
class BlendShapeRecord:
    name: str                     # the shape key's name
    offsets: np.ndarray           # (M, 3) float32, effective offset (masked, minus its relative key)
    indices: np.ndarray           # (M,) int32 points the offsets move


@dataclass
class SkinRecord:
    rig: str                      # SkeletonRecord key
    joint_indices: np.ndarray     # (N, k) int32, into the rig's joints
    joint_weights: np.ndarray     # (N, k) float32, rows sum to 1
    geom_bind: np.ndarray         # (4, 4) float64, Blender convention: mesh -> world at bind
    dual_quaternion: bool = False
    blend_shapes: list = field(default_factory=list)  # BlendShapeRecord
    object: str = ""               # the skinned object's key (names its blend shapes)


@dataclass
class SkeletonRecord:
    """A rig: an armature's bones, or a bone-less host for a mesh's blend shapes.

    With `static_world` set, one more joint follows the bones: a root that never moves,
    bound at `static_world` (the skeleton's world matrix at bind time), for vertices
    Blender leaves undeformed.
    """
    key: str
    name: str
    joint_names: list             # bone names, parents before children
    parents: list                 # parent joint index per joint, -1 for roots
    bind: np.ndarray              # (J, 4, 4) world-space rest matrices (Blender convention)
    rest: np.ndarray              # (J, 4, 4) parent-relative rest matrices
    rest_armature: np.ndarray     # (J, 4, 4) armature-space rest matrices
    static_world: np.ndarray | None = None
    times: list = field(default_factory=list)  # frames; empty: rest pose only
    translations: np.ndarray | None = None     # (T, J, 3), T == 1 when constant
    rotations: np.ndarray | None = None        # (T, J, 4) quaternions (x, y, z, w)
    scales: np.ndarray | None = None           # (T, J, 3)
    blend_shapes: list = field(default_factory=list)  # (object key, shape key name)
    blend_weights: np.ndarray | None = None    # (T, B), T == 1 when constant


@dataclass
class LightRecord:
    kind: str                   # core.lights: point / spot / sun / rect / disk
    color: tuple[float, float, float]
    intensity: float            # USD inputs:intensity, with normalize = true
    shadow: bool
    diffuse: float = 1.0
    specular: float = 1.0
    radius: float = 0.0         # point / spot / disk
    soft_falloff: bool = True
    cone_angle: float = 90.0    # degrees, half angle
    cone_softness: float = 0.0
    angle: float = 0.0          # sun, degrees
    width: float = 1.0          # rect; a disk's diameters along x and y (an ellipse's differ)
    height: float = 1.0
    # Lantern's own shadow settings (`light.lantern` in Blender); the defaults are the
    # add-on's property defaults and mean "not authored".
    shadow_resolution: int = 0  # texels per shadow-map side; 0: the quality preset chooses
    shadow_bias: float = 1.0    # scale of the engine's texel-sized shadow bias


@dataclass
class CameraRecord:
    projection: str             # perspective / orthographic
    focal_length: float         # mm
    horizontal_aperture: float  # mm (tenths of a unit when orthographic)
    vertical_aperture: float
    horizontal_offset: float
    vertical_offset: float
    clip_start: float
    clip_end: float


@dataclass
class WorldRecord:
    name: str
    color: tuple[float, float, float] = (0.05, 0.05, 0.05)
    intensity: float = 1.0
    texture: str | None = None  # absolute path of a lat-long image
    rotation: tuple = (0.0, 0.0, 0.0)  # the texture's Mapping node rotation, Euler XYZ radians
    ao_distance: float | None = None   # world.light_settings.distance (scene units)


@dataclass
class TRS:
    """Transforms that are exactly translate · rotate · scale, one row per time sample
    (one row when static): what USD interpolates as Blender does (rotations by slerp)."""
    translations: np.ndarray      # (T, 3) float64
    rotations: np.ndarray         # (T, 4) unit quaternions (x, y, z, w), neighbours on one hemisphere
    scales: np.ndarray            # (T, 3) float64, negative on x for a mirroring matrix


@dataclass
class PointsRecord:
    """A point cloud: particles or a point cloud's points, in the object's space."""
    name: str
    points: np.ndarray            # (N, 3) float32
    widths: np.ndarray            # (N,) float32 diameters


@dataclass
class CurvesRecord:
    """Curves of one type and wrap (hair), in the object's space (contract: Curves)."""
    name: str
    points: np.ndarray            # (N, 3) float32: control points (Bezier: knots and handles)
    counts: np.ndarray            # (C,) int32 points a curve
    widths: np.ndarray            # float32 diameters, by widths_interpolation
    kind: str                     # linear / cubic (BasisCurves) / nurbs (NurbsCurves)
    basis: str | None = None      # catmullRom / bezier (cubic)
    wrap: str = "nonperiodic"     # nonperiodic / periodic / pinned
    widths_interpolation: str = "vertex"   # vertex, or varying (one a Bezier knot)
    orders: np.ndarray | None = None       # nurbs: (C,) int32
    knots: np.ndarray | None = None        # nurbs: (sum(counts + orders),) float64
    weights: np.ndarray | None = None      # nurbs: (N,) float32


@dataclass
class PrototypeRecord:
    """What one instance draws: an object's evaluated geometry in its own space."""
    key: str
    name: str
    mesh: str | None = None       # MeshRecord key (written under /root/_prototypes)
    materials: list = field(default_factory=list)  # per slot: MaterialRecord key or None
    points: PointsRecord | None = None


@dataclass
class InstancesRecord:
    """Instances an object generates (collection, geometry nodes, particles, vertices),
    placed relative to that object."""
    prototypes: list              # PrototypeRecord keys; proto_indices index this list
    proto_indices: np.ndarray     # (M,) int32
    matrices: np.ndarray          # (M, 4, 4) float64, instance -> instancer object space
    trs: TRS | None = None        # the matrices as TRS (rows where `exact`)
    exact: np.ndarray | None = None  # (M,) bool: False where a matrix shears


@dataclass
class ObjectRecord:
    key: str                     # Blender's unique object name
    name: str
    parent: str | None           # key of the exported parent, None: under /root
    matrix: np.ndarray           # (4, 4) float64, row-major Blender matrix, local
    kind: str                    # mesh / light / camera / empty
    mesh: str | None = None      # MeshRecord key
    shared: bool = False         # mesh is a prototype under /root/_prototypes
    materials: list = field(default_factory=list)  # per slot: MaterialRecord key or None
    light: LightRecord | None = None
    camera: CameraRecord | None = None
    rig: str | None = None       # SkeletonRecord key: this object's prim is a SkelRoot
    matrix_samples: np.ndarray | None = None  # (T, 4, 4) local matrices at settings.times
    trs: TRS | None = None       # the matrix (or its samples) as TRS, None when sheared
    points: PointsRecord | None = None        # particles or a point cloud it shows
    curves: list = field(default_factory=list)  # CurvesRecord: its hair curves
    instances: InstancesRecord | None = None  # instances it generates
    pass_index: int = 0          # Blender's object pass index (render pass IndexOB)


@dataclass
class SceneRecord:
    settings: StageSettings = field(default_factory=StageSettings)
    objects: list = field(default_factory=list)       # parents before children
    meshes: dict = field(default_factory=dict)        # key -> MeshRecord
    materials: dict = field(default_factory=dict)     # key -> MaterialRecord
    world: WorldRecord | None = None
    skeletons: dict = field(default_factory=dict)     # key -> SkeletonRecord
    prototypes: dict = field(default_factory=dict)    # key -> PrototypeRecord
    times: list = field(default_factory=list)         # sampled frames; empty: static scene
    warnings: list = field(default_factory=list)
