"""WorldRecord -> the /root/_world DomeLight, oriented as Blender shows the world.

UsdLux's DomeLight maps its lat-long texture in its own frame with +Y up (the OpenEXR
convention: the image centre looks along local +Z, u = 0.25 along local +X); Blender's
Environment Texture maps it with +Z up and the image centre along world +X (u = 0.25
along +Y). The dome's transform takes one to the other: local +X -> world +Y,
local +Y -> world +Z, local +Z -> world +X (the same turn Blender's own USD exporter
writes, Rx(90) then Rz(90)), after the inverse of the Environment Texture's Mapping
rotation. See docs/stage_contract.md, "World"."""
import math

import numpy as np
from pxr import Gf, UsdGeom, UsdLux

from .light import write_common
from .names import set_blender_name

# Columns: the world directions of the dome's local X, Y, Z (column-vector convention).
DOME_TO_BLENDER = np.array([[0.0, 0.0, 1.0],
                            [1.0, 0.0, 0.0],
                            [0.0, 1.0, 0.0]])


def euler_xyz(rotation):
    """Blender's Euler XYZ as a matrix acting on column vectors: Rz @ Ry @ Rx."""
    a, b, c = rotation
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return rz @ ry @ rx


def dome_matrix(rotation=(0.0, 0.0, 0.0)):
    """Dome-local -> world rotation (column vectors). The Mapping node looks the
    texture up at R d for a world direction d, so the dome turns by R^-1."""
    return euler_xyz(rotation).T @ DOME_TO_BLENDER


def write_world(stage, path, rec, asset_path):
    dome = UsdLux.DomeLight.Define(stage, path)
    write_common(dome, rec.color, rec.intensity, True)
    if rec.texture:
        dome.CreateTextureFileAttr(asset_path(rec.texture))
        dome.CreateTextureFormatAttr(UsdLux.Tokens.latlong)
        m = np.identity(4)
        m[:3, :3] = dome_matrix(rec.rotation).T     # USD matrices act on row vectors
        UsdGeom.Xformable(dome).AddTransformOp().Set(Gf.Matrix4d(*m.ravel().tolist()))
    set_blender_name(dome.GetPrim(), rec.name)
    return dome
