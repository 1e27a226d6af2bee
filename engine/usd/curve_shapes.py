"""What the engine draws of curves (curves.py samples them), as Storm and Cycles draw
curves: where normals are authored, ribbons facing them (`ribbon_surface`: faces for
build_mesh, drawn as meshes); otherwise round tubes (`tubes`: the Points prims'
ray-cast primitive, a sphere swept along each straight piece with its radius varying
linearly: Cycles' 3D curves), which cast and receive shadows like any surface."""
from __future__ import annotations

import math

import numpy as np
from pxr import UsdGeom

from .curves import Polylines, finite, polylines
from .mesh import MeshError, Surface

SHARP_TURN = math.radians(20.0)    # a sample where a ribbon turns more is a corner


def tangents(lines: Polylines) -> np.ndarray:
    """Unit tangents at the samples (central differences along each curve,
    one-sided at an open curve's ends)."""
    prev, nxt = lines.neighbours()
    t = lines.points[nxt] - lines.points[prev]
    return t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)


def _report(prim, lines, warnings):
    if lines.skipped and warnings is not None:
        warnings.append(f"{prim.GetPath()}: {lines.skipped}")


def ribbon_surface(prim, time, warnings=None, points=None) -> Surface:
    """Oriented ribbons: each straight piece of a curve a quad, `widths` wide across
    the curve in the plane the authored normal faces (the normal made perpendicular
    to the curve), carrying that normal. Where a curve bends smoothly, neighbouring
    pieces share their edge (across the mean direction); at a corner (a turn over
    SHARP_TURN: a linear curve's vertices) each piece ends square to itself, so the
    ribbon keeps its width. `points`: skinned ones in place of the prim's. MeshError
    naming a defect."""
    try:
        lines = polylines(prim, time, points)
    except ValueError as exc:
        raise MeshError(str(exc)) from None
    _report(prim, lines, warnings)
    seg = lines.segments()
    if not len(seg):
        raise MeshError("no curve has two samples")
    a, b = seg[:, 0], seg[:, 1]
    own = lines.points[b] - lines.points[a]
    own /= np.maximum(np.linalg.norm(own, axis=1, keepdims=True), 1e-30)
    # A sample is a corner where the piece ending there and the one starting there turn
    # sharply (pieces are listed curve by curve, closing pieces last).
    into = np.full(len(lines.points), -1)
    into[b] = np.arange(len(seg))
    meets = into[a] >= 0
    turn = np.einsum("ij,ij->i", own[into[a][meets]], own[meets])
    corner = np.zeros(len(lines.points), bool)
    corner[a[meets][turn < math.cos(SHARP_TURN)]] = True
    mean = tangents(lines)
    ends, normals, sides = [], [], []
    for sample in (a, b):
        t = np.where(corner[sample][:, None], own, mean[sample])
        n = lines.normals[sample]
        n = n - t * np.sum(n * t, axis=1, keepdims=True)
        length = np.linalg.norm(n, axis=1, keepdims=True)
        if (length == 0).any() and warnings is not None:
            warnings.append(f"{prim.GetPath()}: {int((length == 0).sum())} curve normals lie "
                            f"along their curve or are zero; the ribbon has no width there")
        n = n / np.maximum(length, 1e-30)
        ends.append(lines.points[sample])
        normals.append(n)
        sides.append(np.cross(t, n) * (lines.widths[sample][:, None] / 2))
    s = len(seg)
    # Per piece: a-, a+, b+, b- winds counter-clockwise about the normal (side = t x n).
    points = np.stack([ends[0] - sides[0], ends[0] + sides[0], ends[1] + sides[1],
                       ends[1] - sides[1]], axis=1).reshape(-1, 3)
    return Surface(points=points, counts=np.full(s, 4), indices=np.arange(4 * s),
                   normals=np.stack([normals[0], normals[0], normals[1], normals[1]],
                                    axis=1).reshape(-1, 3),
                   point_source=np.stack([lines.source[a]] * 2 + [lines.source[b]] * 2,
                                         axis=1).reshape(-1),
                   face_source=lines.curve[a])


def tubes(prim, time, warnings=None, points=None):
    """(points (m, 3), radii (m,), colours (m, 3) or None, segments (s, 2)) of the
    round tubes; ValueError naming a defect. Colours are displayColor's, per curve,
    vertex or constant. `points`: skinned ones in place of the prim's."""
    lines = polylines(prim, time, points)
    _report(prim, lines, warnings)
    seg = lines.segments()
    if not len(seg):
        raise ValueError("no curve has two samples")
    colours = None
    pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
    if pv and pv.HasValue():
        c = pv.ComputeFlattened(time)
        if c is not None and len(c):
            c = np.asarray(c, np.float64).reshape(-1, 3)
            finite(c, "displayColor values")
            interp = str(pv.GetInterpolation())
            if len(c) == 1 or interp == "constant":
                colours = np.repeat(c[:1], len(lines.points), axis=0)
            elif interp == "uniform" and len(c) > lines.curve.max():
                colours = c[lines.curve]
            elif interp in ("vertex", "varying") and len(c) > lines.source.max():
                colours = c[lines.source]
    return lines.points, lines.widths / 2.0, colours, seg
