"""Plain records of what gets drawn. No pxr, no GL: the reader fills them, the
renderer consumes them.

Matrices are numpy float64 4x4 in column-vector convention (p' = M @ p), so a
matrix goes to GLSL as `M.T` bytes (column-major)."""
from __future__ import annotations

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


@dataclass
class DrawItem:
    mesh_key: tuple
    world: np.ndarray              # 4x4
    prim_path: str = ""


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
