"""UsdGeom.NurbsPatch -> the faces the engine draws of it: its control hull, as Storm
draws a NurbsPatch (no records, no GL).

The uVertexCount x vVertexCount control points (u varying fastest) become a grid of
quads, one between each four neighbouring points, wound by the patch's
`orientation`, with smooth normals (build_mesh's own, as Storm shades its hull). The
knots, orders, weights, ranges and trim curves are not evaluated: the hull encloses
the surface and touches it only where the patch interpolates its points (corners of
a clamped patch; everywhere for order 2)."""
from __future__ import annotations

import numpy as np
from pxr import UsdGeom

from .mesh import MeshError, Surface


def is_patch(prim) -> bool:
    return prim.GetTypeName() == "NurbsPatch" and prim.IsA(UsdGeom.NurbsPatch)


def hull_surface(prim, time) -> Surface:
    """The control hull of a NurbsPatch prim; MeshError naming a defect."""
    patch = UsdGeom.NurbsPatch(prim)
    nu = patch.GetUVertexCountAttr().Get(time)
    nv = patch.GetVVertexCountAttr().Get(time)
    points = patch.GetPointsAttr().Get(time)
    if nu is None or nv is None or nu < 2 or nv < 2:
        raise MeshError(f"uVertexCount {nu} and vVertexCount {nv} (2 each at least)")
    n = 0 if points is None else len(points)
    if n != nu * nv:
        raise MeshError(f"{n} points for uVertexCount x vVertexCount = {nu * nv}")
    grid = np.arange(n).reshape(nv, nu)
    quads = np.stack([grid[:-1, :-1], grid[:-1, 1:], grid[1:, 1:], grid[1:, :-1]],
                     axis=-1).reshape(-1, 4)
    if patch.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded:
        quads = quads[:, ::-1]
    return Surface(points=np.asarray(points, np.float64), counts=np.full(len(quads), 4),
                   indices=quads.reshape(-1), normals=None, point_source=np.arange(n))
