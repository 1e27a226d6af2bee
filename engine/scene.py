"""Plain records of what gets drawn. No pxr, no GL: the reader fills them, the
renderer consumes them.

Matrices are numpy float64 4x4 in column-vector convention (p' = M @ p), so a
matrix goes to GLSL as `M.T` bytes (column-major)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class TextureRef:
    path: str                      # resolved absolute path
    colorspace: str = "auto"       # sRGB | raw | auto
    wrap_s: str = "repeat"         # repeat | mirror | clamp | black
    wrap_t: str = "repeat"
    scale: tuple = (1.0, 1.0, 1.0, 1.0)
    bias: tuple = (0.0, 0.0, 0.0, 0.0)
    channel: str = "rgb"           # rgb | r | g | b | a


@dataclass
class Material:
    name: str
    diffuse: tuple = (0.18, 0.18, 0.18)
    metallic: float = 0.0
    roughness: float = 0.5
    ior: float = 1.5
    emissive: tuple = (0.0, 0.0, 0.0)
    opacity: float = 1.0
    opacity_threshold: float = 0.0
    # input name ('diffuseColor', 'normal', ...) -> TextureRef
    maps: dict = field(default_factory=dict)
    uv_name: str | None = None     # primvar the material's reader asks for

    @property
    def has_normal_map(self) -> bool:
        return "normal" in self.maps


@dataclass
class MeshData:
    """De-indexed triangle soup, sorted by material. vertices: (N, 12) float32 =
    position 3, normal 3, uv 2, tangent 4 (w = handedness)."""
    key: tuple
    vertices: np.ndarray
    ranges: list                   # [(material_index, first_vertex, vertex_count)]
    materials: list                # [Material], indexed by ranges
    double_sided: bool = True
    point_index: np.ndarray | None = None  # (N,) int32: soup vertex -> mesh point
    skin: "SkinData | None" = None          # UsdSkel binding (engine/skinning.py)


@dataclass
class SkinData:
    """A mesh's static UsdSkel binding, per soup vertex. Joint indices are in the
    skeleton's order (the binding's joint mapper already applied); index n_joints is
    an identity joint for mesh joints the skeleton lacks."""
    skel_key: str = ""
    n_points: int = 0
    joints: np.ndarray | None = None       # (N, 4g) int32, or None: blend shapes only
    weights: np.ndarray | None = None      # (N, 4g) float32
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
class DrawItem:
    mesh_key: tuple
    world: np.ndarray              # 4x4 (skinned: the skeleton's local-to-world)
    prim_path: str = ""
    # This frame's blend shapes: [(sub-shape index, weight)], zero weights left out.
    shapes: list = field(default_factory=list)


@dataclass
class SkelPose:
    """A skeleton at one time: UsdSkel skinning transforms (skeleton space, column-
    vector), plus the identity joint at index n_joints."""
    xforms: np.ndarray             # (n_joints + 1, 4, 4)
    dqs: bool = False              # a bound mesh skins with dual quaternions


@dataclass
class Light:
    """kind: sphere | spot | distant | rect | disk. `color` is already radiometric:
    radiant intensity I [W/sr] for sphere/spot, radiance L [W/(sr m2)] for rect/disk,
    irradiance E [W/m2] for distant."""
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
    sh: np.ndarray                 # (9, 3) irradiance SH coefficients, see lights.dome_sh
    texture: str | None = None     # lat-long image shown as the background
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))  # dome local -> world


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
    meshes: dict = field(default_factory=dict)     # key -> MeshData
    draws: list = field(default_factory=list)      # [DrawItem]
    lights: list = field(default_factory=list)
    dome: Dome | None = None
    camera: Camera | None = None
    warnings: list = field(default_factory=list)
    meters_per_unit: float = 1.0
    up_axis: str = "Z"
    bounds: tuple | None = None                    # (min xyz, max xyz) world
    skeletons: dict = field(default_factory=dict)  # skel key -> SkelPose
