"""UsdGeom.BasisCurves and NurbsCurves -> polylines of the curves' own shape (no
records, no GL), and what the engine draws of them.

Every basis is evaluated on the CPU: linear; cubic bezier, bspline and catmullRom
(each segment as its Bezier control points), with the nonperiodic, periodic and
pinned wraps (pinned adds UsdGeomBasisCurves' phantom points, 2 P0 - P1 and
2 Pn-1 - Pn-2, so the curve starts and ends on its end points); NurbsCurves of any
order by de Boor's algorithm over their knots, rational where pointWeights are
authored, each curve over its `ranges`. Each cubic span is cut into straight pieces
until the polyline is within TOLERANCE of the prim's size from the curve (at most
MAX_PIECES a span). Widths (constant, uniform, vertex, varying) and normals are
interpolated as USD says: vertex values by the curve's basis, varying ones linearly
over each segment.

Drawn as Storm and Cycles draw curves: where normals are authored, as ribbons facing
them (`ribbon_surface`: meshes, build_mesh's `surface`); otherwise as round tubes
(`tube_data`: the Points prims' ray-cast primitive, a sphere swept along each
straight piece, its radius varying linearly: Cycles' 3D curves), which cast and
receive shadows like any surface. Primvars reach the samples from their nearest
control vertex (vertex, varying) or their curve (uniform). A defect (counts that do
not add up, too few points for the basis, a knot vector of the wrong length) is a
ValueError naming it; the reader skips the prim with a warning."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pxr import UsdGeom

from .mesh import MeshError, Surface

TOLERANCE = 2.5e-4             # polyline to curve, over the prim's bounding-box diagonal
MAX_PIECES = 64                # straight pieces per cubic span at most
DEFAULT_WIDTH = 1.0            # unauthored widths, as Storm


@dataclass
class Polylines:
    """The curves of a prim sampled: `points` (m, 3) with their `widths` (m,) and
    `normals` (m, 3) or None; curve i is samples starts[i]:starts[i+1], closed
    (its last sample joins its first) where `closed[i]`. `source`: the control vertex
    nearest each sample; `curve`: each sample's curve."""
    points: np.ndarray
    widths: np.ndarray
    normals: np.ndarray | None
    starts: np.ndarray
    closed: np.ndarray
    source: np.ndarray
    curve: np.ndarray
    skipped: str | None = None     # curves left out (too few vertices for the basis)

    def segments(self) -> np.ndarray:
        """(s, 2) sample index pairs of the straight pieces."""
        pairs = []
        for i in range(len(self.starts) - 1):
            a, b = int(self.starts[i]), int(self.starts[i + 1])
            idx = np.arange(a, b)
            if self.closed[i] and b - a > 2:
                pairs.append(np.stack([idx, np.roll(idx, -1)], axis=1))
            elif b - a > 1:
                pairs.append(np.stack([idx[:-1], idx[1:]], axis=1))
        return np.concatenate(pairs) if pairs else np.zeros((0, 2), np.int64)


def has_normals(prim) -> bool:
    attr = UsdGeom.PointBased(prim).GetNormalsAttr()
    return bool(attr) and attr.HasAuthoredValue()


def _array(attr, time, dtype=np.float64):
    if not attr or not attr.HasValue():
        return None
    v = attr.Get(time)
    return None if v is None else np.asarray(v, dtype)


def _finite(values, what):
    bad = ~np.isfinite(values)
    if bad.ndim > 1:
        bad = bad.any(axis=1)
    if bad.any():
        raise ValueError(f"{int(bad.sum())} of {len(bad)} {what} are not finite")


# Cubic bases as Bezier control points of the segment on P0..P3 (rows: b0..b3).
_TO_BEZIER = {
    "bezier": np.eye(4),
    "bspline": np.array([[1, 4, 1, 0], [0, 4, 2, 0], [0, 2, 4, 0], [0, 1, 4, 1]]) / 6.0,
    "catmullRom": np.array([[0, 6, 0, 0], [-1, 6, 1, 0], [0, 1, 6, -1], [0, 0, 6, 0]]) / 6.0,
}


def _bernstein(u):
    v = 1.0 - u
    return np.stack([v * v * v, 3 * v * v * u, 3 * v * u * u, u * u * u], axis=-1)


@dataclass
class _Layout:
    """One curve's segments: control vertex indices (nseg, 4) (cubic) or (nseg, 2)
    (linear) into the (pinned: padded) points, and whether it closes."""
    controls: np.ndarray
    closed: bool
    padded: bool            # pinned phantom points added: index 0 and n+1 are phantoms


def _layout(n, kind, basis, wrap) -> _Layout:
    if kind == "linear":
        if n < 2:
            raise ValueError(f"a linear curve of {n} vertex")
        closed = wrap == "periodic" and n > 2
        i = np.arange(n if closed else n - 1)
        return _Layout(np.stack([i, (i + 1) % n], axis=1), closed, False)
    if basis == "bezier":
        if wrap == "periodic":
            if n < 3 or n % 3:
                raise ValueError(f"a periodic bezier curve of {n} vertices (3 a segment)")
            i = np.arange(0, n, 3)
            return _Layout((i[:, None] + np.arange(4)) % n, True, False)
        if n < 4 or (n - 4) % 3:
            raise ValueError(f"a bezier curve of {n} vertices (4, 7, 10, ...)")
        i = np.arange(0, n - 3, 3)
        return _Layout(i[:, None] + np.arange(4), False, False)
    if wrap == "periodic":
        if n < 3:
            raise ValueError(f"a periodic {basis} curve of {n} vertices")
        i = np.arange(n)
        return _Layout((i[:, None] + np.arange(4)) % n, True, False)
    if wrap == "pinned":
        if n < 2:
            raise ValueError(f"a pinned {basis} curve of {n} vertex")
        i = np.arange(n - 1)
        return _Layout(i[:, None] + np.arange(4), False, True)
    if n < 4:
        raise ValueError(f"a {basis} curve of {n} vertices (4 at least)")
    i = np.arange(n - 3)
    return _Layout(i[:, None] + np.arange(4), False, False)


def _pad(values):
    """Pinned curves' phantom values: 2 v0 - v1 before, 2 vn-1 - vn-2 after."""
    if len(values) < 2:
        return np.concatenate([values, values, values])
    return np.concatenate([2 * values[:1] - values[1:2], values, 2 * values[-1:] - values[-2:-1]])


def _per_curve(values, interp, counts, varying, what):
    """[values of curve i] per curve for a primvar, or ValueError. One value is
    constant whatever its interpolation (as the Points prims' widths)."""
    n_curves = len(counts)
    if interp == "constant" or len(values) == 1:
        return [np.repeat(values[:1], c, axis=0) for c in counts], "vertex"
    sizes = {"uniform": [1] * n_curves, "vertex": list(counts),
             "varying": varying, "faceVarying": varying}.get(interp)
    if sizes is None:
        raise ValueError(f"{what} has interpolation {interp}")
    if len(values) != sum(sizes):
        raise ValueError(f"{what} has {len(values)} {interp} values for {sum(sizes)}")
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    parts = [values[offsets[i]:offsets[i + 1]] for i in range(n_curves)]
    if interp == "uniform":
        return [np.repeat(p, c, axis=0) for p, c in zip(parts, counts)], "vertex"
    return parts, "varying" if interp in ("varying", "faceVarying") else "vertex"


def _pieces(bez, tol):
    """Straight pieces per cubic span (Bezier control points (s, 4, 3)): the polyline
    of k pieces is within max|B''| / (8 k^2) of the curve."""
    second = np.maximum(np.linalg.norm(bez[:, 0] - 2 * bez[:, 1] + bez[:, 2], axis=1),
                        np.linalg.norm(bez[:, 1] - 2 * bez[:, 2] + bez[:, 3], axis=1))
    k = np.ceil(np.sqrt(6.0 * second / (8.0 * max(tol, 1e-30))))
    return np.clip(k, 1, MAX_PIECES).astype(np.int64)


def basis_curves(prim, time) -> Polylines:
    """The samples of a BasisCurves prim; ValueError naming a defect."""
    curves = UsdGeom.BasisCurves(prim)
    pts = _array(curves.GetPointsAttr(), time)
    counts = _array(curves.GetCurveVertexCountsAttr(), time, np.int64)
    if pts is None or counts is None or not len(pts) or not len(counts):
        raise ValueError("no points or curveVertexCounts")
    pts = pts.reshape(-1, 3)
    if (counts < 1).any() or counts.sum() != len(pts):
        raise ValueError(f"curveVertexCounts add up to {counts.sum()} for {len(pts)} points")
    _finite(pts, "points")
    kind = curves.GetTypeAttr().Get(time) or "cubic"
    basis = curves.GetBasisAttr().Get(time) or "bezier"
    wrap = curves.GetWrapAttr().Get(time) or "nonperiodic"
    if kind not in ("linear", "cubic") or basis not in _TO_BEZIER or \
            wrap not in ("nonperiodic", "periodic", "pinned"):
        raise ValueError(f"type {kind}, basis {basis}, wrap {wrap} is not one USD defines")
    layouts, bad = [], []
    for c in counts:
        try:
            layouts.append(_layout(int(c), kind, basis, wrap))
        except ValueError as exc:         # that curve alone is left out (as Storm does)
            layouts.append(None)
            bad.append(str(exc))
    varying = [_nominal_varying(int(c), kind, basis, wrap) if lay is None else
               len(lay.controls) + (0 if lay.closed else 1) for c, lay in zip(counts, layouts)]
    widths = _widths(curves, time, counts, varying)
    normals = _normals(curves, time, counts, varying)
    diagonal = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    tol = TOLERANCE * max(diagonal, 1e-30)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    out = []
    for i, lay in enumerate(layouts):
        if lay is None:
            continue
        p = pts[offsets[i]:offsets[i + 1]]
        w, n = widths[0][i], None if normals is None else normals[0][i]
        out.append(_sample(p, w, n, widths[1], None if normals is None else normals[1],
                           lay, kind, basis, tol, int(offsets[i])) + (i,))
    if not out:
        raise ValueError(bad[0])
    lines = _join(out)
    if bad:
        lines.skipped = f"{len(bad)} of {len(counts)} curves are not drawn ({bad[0]})"
    return lines


def _nominal_varying(n, kind, basis, wrap):
    """Varying values a curve of n vertices has by USD's counting, where its basis and
    wrap give it no segment (the primvar still holds its share)."""
    if kind == "linear":
        return n
    if basis == "bezier":
        return n // 3 if wrap == "periodic" else max((n - 4) // 3 + 2, 0)
    return n if wrap in ("periodic", "pinned") else max(n - 2, 0)


def _widths(curves, time, counts, varying):
    pv = UsdGeom.PrimvarsAPI(curves).GetPrimvar("widths")
    values, interp = None, None
    if pv and pv.HasValue():
        v = pv.ComputeFlattened(time)
        if v is not None and len(v):
            values, interp = np.asarray(v, np.float64).reshape(-1), str(pv.GetInterpolation())
    if values is None:
        a = curves.GetWidthsAttr()
        v = a.Get(time) if a.HasValue() else None
        if v is not None and len(v):
            values, interp = np.asarray(v, np.float64).reshape(-1), str(curves.GetWidthsInterpolation())
    if values is None:
        values, interp = np.array([DEFAULT_WIDTH]), "constant"
    _finite(values, "widths")
    if (values < 0).any():
        raise ValueError("negative widths")
    return _per_curve(values, interp, counts, varying, "widths")


def _normals(curves, time, counts, varying):
    a = curves.GetNormalsAttr()
    v = a.Get(time) if a and a.HasAuthoredValue() else None
    if v is None or not len(v):
        return None
    values = np.asarray(v, np.float64).reshape(-1, 3)
    _finite(values, "normals")
    return _per_curve(values, str(curves.GetNormalsInterpolation()), counts, varying, "normals")


def _sample(p, w, n, w_interp, n_interp, lay, kind, basis, tol, first):
    """One curve's samples: (points, widths, normals or None, source vertex, closed)."""
    src = np.arange(len(p)) + first
    if lay.padded:
        p = _pad(p)
        src = np.concatenate([src[:1], src, src[-1:]])
        if w_interp == "vertex":
            w = np.maximum(_pad(w), 0.0)
        if n is not None and n_interp == "vertex":
            n = _pad(n)
    ctrl = lay.controls
    nseg = len(ctrl)
    if kind == "linear":
        bez = np.stack([p[ctrl[:, 0]], p[ctrl[:, 0]], p[ctrl[:, 1]], p[ctrl[:, 1]]], axis=1)
        k = np.ones(nseg, np.int64)
        m = np.array([[1, 0], [1, 0], [0, 1], [0, 1]], np.float64)   # as Bezier, straight
        ends = ctrl
    else:
        m = _TO_BEZIER[basis]
        bez = np.einsum("ij,sjk->sik", m, p[ctrl])
        k = _pieces(bez, tol)
        ends = ctrl[:, [0, 3]] if basis == "bezier" else ctrl[:, [1, 2]]
    seg = np.repeat(np.arange(nseg), k)
    u = np.concatenate([np.arange(kk) / kk for kk in k])
    if not lay.closed:                   # the curve's end point
        seg, u = np.append(seg, nseg - 1), np.append(u, 1.0)
    b = _bernstein(u)
    points = np.einsum("mj,mjk->mk", b, bez[seg])

    def along(values, interp):
        if interp == "varying":
            nxt = (np.arange(nseg) + 1) % len(values)
            a, c = values[np.arange(nseg)][seg], values[nxt][seg]
            t = u.reshape((-1,) + (1,) * (values.ndim - 1))
            return a * (1 - t) + c * t
        cv = values[ctrl]                                  # (nseg, 4|2, ...)
        if kind == "linear":
            t = u.reshape((-1,) + (1,) * (values.ndim - 1))
            return cv[seg, 0] * (1 - t) + cv[seg, 1] * t
        cb = np.einsum("ij,sj...->si...", m, cv)
        return np.einsum("mj,mj...->m...", b, cb[seg])

    widths = np.maximum(along(w, w_interp), 0.0)
    normals = None if n is None else along(n, n_interp)
    # Each sample's nearest control vertex: its segment's start or end.
    source = np.where(u < 0.5, src[ends[seg, 0]], src[ends[seg, 1]])
    return points, widths, normals, source, lay.closed


def _join(curves) -> Polylines:
    """Polylines of [(points, widths, normals, source, closed, curve index)]."""
    sizes = [len(c[0]) for c in curves]
    normals = None if curves[0][2] is None else np.concatenate([c[2] for c in curves])
    return Polylines(points=np.concatenate([c[0] for c in curves]),
                     widths=np.concatenate([c[1] for c in curves]), normals=normals,
                     starts=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
                     closed=np.array([c[4] for c in curves], bool),
                     source=np.concatenate([c[3] for c in curves]).astype(np.int64),
                     curve=np.repeat([c[5] for c in curves], sizes))


def nurbs_curves(prim, time) -> Polylines:
    """The samples of a NurbsCurves prim (order, knots, ranges, pointWeights); widths
    and normals by vertex are weighted by the same basis functions."""
    curves = UsdGeom.NurbsCurves(prim)
    pts = _array(curves.GetPointsAttr(), time)
    counts = _array(curves.GetCurveVertexCountsAttr(), time, np.int64)
    order = _array(curves.GetOrderAttr(), time, np.int64)
    knots = _array(curves.GetKnotsAttr(), time)
    if pts is None or counts is None or order is None or knots is None or not len(counts):
        raise ValueError("no points, curveVertexCounts, order or knots")
    pts = pts.reshape(-1, 3)
    if (counts < 1).any() or counts.sum() != len(pts):
        raise ValueError(f"curveVertexCounts add up to {counts.sum()} for {len(pts)} points")
    if len(order) != len(counts) or (order < 2).any() or (order > counts).any():
        raise ValueError("an order per curve, from 2 to its vertex count, is needed")
    if len(knots) != int((counts + order).sum()):
        raise ValueError(f"{len(knots)} knots for {int((counts + order).sum())}")
    _finite(pts, "points")
    _finite(knots, "knots")
    weights = _array(curves.GetPointWeightsAttr(), time)
    if weights is not None and len(weights) != len(pts):
        weights = None
    ranges = _array(curves.GetRangesAttr(), time)
    varying = [int(c - o + 2) for c, o in zip(counts, order)]
    widths = _widths(curves, time, counts, varying)
    normals = _normals(curves, time, counts, varying)
    diagonal = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    tol = TOLERANCE * max(diagonal, 1e-30)
    out, at, kat = [], 0, 0
    for i, (c, o) in enumerate(zip(counts, order)):
        c, o = int(c), int(o)
        t = knots[kat:kat + c + o]
        if (np.diff(t) < 0).any():
            raise ValueError(f"curve {i}'s knots decrease")
        lo, hi = t[o - 1], t[c]
        if ranges is not None and len(ranges) == len(counts):
            lo, hi = max(lo, ranges[i][0]), min(hi, ranges[i][1])
        if not hi > lo:
            raise ValueError(f"curve {i} has an empty parameter range")
        p = pts[at:at + c]
        wt = np.ones(c) if weights is None else weights[at:at + c]
        spans = np.unique(t[(t > lo) & (t < hi)])
        breaks = np.concatenate([[lo], spans, [hi]])
        # Pieces per span from the control polygon's bend (as the cubic spans').
        bend = np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=1).max() if c > 2 else 0.0
        k = 1 if o == 2 else int(np.clip(np.ceil(np.sqrt(bend / max(tol, 1e-30))), 2, MAX_PIECES))
        u = np.concatenate([np.linspace(a, b, k, endpoint=False) for a, b in
                            zip(breaks[:-1], breaks[1:])] + [[hi]])
        basis = _bspline_basis(t, o, c, u)                       # (m, c)
        rational = basis * wt
        denom = rational.sum(axis=1, keepdims=True)
        points = rational @ p / np.where(denom == 0, 1, denom)
        w, w_interp = widths[0][i], widths[1]
        wv = basis @ w if w_interp == "vertex" else np.interp(
            np.linspace(0, 1, len(u)), np.linspace(0, 1, len(w)), w)
        nv = None
        if normals is not None:
            n = normals[0][i]
            nv = basis @ n if normals[1] == "vertex" else np.stack(
                [np.interp(np.linspace(0, 1, len(u)), np.linspace(0, 1, len(n)), n[:, j])
                 for j in range(3)], axis=1)
        source = at + np.argmax(basis, axis=1)
        out.append((points, np.maximum(wv, 0.0), nv, source, False, i))
        at += c
        kat += c + o
    return _join(out)


def _bspline_basis(t, order, n, u):
    """(m, n) B-spline basis functions of `order` over knots `t` at parameters u
    (Cox-de Boor), u = t[n] taken from the left."""
    u = np.asarray(u, np.float64)
    span = np.clip(np.searchsorted(t, u, side="right") - 1, order - 1, n - 1)
    m = len(u)
    basis = np.zeros((m, len(t) - 1))
    basis[np.arange(m), span] = 1.0
    for d in range(1, order):
        nxt = np.zeros((m, len(t) - 1 - d))
        for j in range(len(t) - 1 - d):
            left = t[j + d] - t[j]
            right = t[j + d + 1] - t[j + 1]
            a = (u - t[j]) / left * basis[:, j] if left > 0 else 0.0
            b = (t[j + d + 1] - u) / right * basis[:, j + 1] if right > 0 else 0.0
            nxt[:, j] = a + b
        basis = nxt
    return basis[:, :n]


def polylines(prim, time) -> Polylines:
    if prim.IsA(UsdGeom.NurbsCurves):
        return nurbs_curves(prim, time)
    return basis_curves(prim, time)


def tangents(lines: Polylines) -> np.ndarray:
    """Unit tangents at the samples (central differences along each curve)."""
    p = lines.points
    t = np.zeros_like(p)
    for i in range(len(lines.starts) - 1):
        a, b = int(lines.starts[i]), int(lines.starts[i + 1])
        q = p[a:b]
        if len(q) < 2:
            continue
        if lines.closed[i]:
            d = np.roll(q, -1, axis=0) - np.roll(q, 1, axis=0)
        else:
            d = np.empty_like(q)
            d[1:-1] = q[2:] - q[:-2]
            d[0], d[-1] = q[1] - q[0], q[-1] - q[-2]
        t[a:b] = d
    return t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)


SHARP_TURN = math.radians(20.0)    # a sample where a ribbon turns more is a corner


def ribbon_surface(prim, time, warnings=None) -> Surface:
    """Oriented ribbons: each straight piece of a curve a quad, `widths` wide across
    the curve in the plane the authored normal faces (the normal made perpendicular
    to the curve), carrying that normal. Where a curve bends smoothly, neighbouring
    pieces share their edge (across the mean direction); at a corner (a turn over
    SHARP_TURN: a linear curve's vertices) each piece ends square to itself, so the
    ribbon keeps its width. MeshError naming a defect."""
    try:
        lines = polylines(prim, time)
    except ValueError as exc:
        raise MeshError(str(exc)) from None
    if lines.skipped and warnings is not None:
        warnings.append(f"{prim.GetPath()}: {lines.skipped}")
    seg = lines.segments()
    if not len(seg):
        raise MeshError("no curve has two samples")
    a, b = seg[:, 0], seg[:, 1]
    own = lines.points[b] - lines.points[a]
    own /= np.maximum(np.linalg.norm(own, axis=1, keepdims=True), 1e-30)
    mean = tangents(lines)
    corner = np.zeros(len(lines.points), bool)
    turn = np.einsum("ij,ij->i", own[:-1], own[1:])
    joined = b[:-1] == a[1:]
    corner[b[:-1][joined & (turn < math.cos(SHARP_TURN))]] = True
    if lines.closed.any():                       # a closed curve's last piece meets its first
        for i in np.flatnonzero(lines.closed):
            first, last = int(lines.starts[i]), int(lines.starts[i + 1]) - 1
            at = np.flatnonzero((a == first))
            end = np.flatnonzero((b == first) & (a == last))
            if len(at) and len(end) and own[at[0]] @ own[end[0]] < math.cos(SHARP_TURN):
                corner[first] = True
    ends, normals, sides = [], [], []
    for sample, direction in ((a, own), (b, own)):
        t = np.where(corner[sample][:, None], direction, mean[sample])
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


def tubes(prim, time, warnings=None):
    """(points (m, 3), radii (m,), colours (m, 3) or None, segments (s, 2)) of the
    round tubes; ValueError naming a defect. Colours are displayColor's, per curve,
    vertex or constant."""
    lines = polylines(prim, time)
    if lines.skipped and warnings is not None:
        warnings.append(f"{prim.GetPath()}: {lines.skipped}")
    seg = lines.segments()
    if not len(seg):
        raise ValueError("no curve has two samples")
    colours = None
    pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
    if pv and pv.HasValue():
        c = pv.ComputeFlattened(time)
        if c is not None and len(c):
            c = np.asarray(c, np.float64).reshape(-1, 3)
            _finite(c, "displayColor values")
            interp = str(pv.GetInterpolation())
            if len(c) == 1 or interp == "constant":
                colours = np.repeat(c[:1], len(lines.points), axis=0)
            elif interp == "uniform" and len(c) > lines.curve.max():
                colours = c[lines.curve]
            elif interp in ("vertex", "varying") and len(c) > lines.source.max():
                colours = c[lines.source]
    return lines.points, lines.widths / 2.0, colours, seg
