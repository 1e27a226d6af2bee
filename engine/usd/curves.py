"""UsdGeom.BasisCurves and NurbsCurves -> polylines of the curves' own shape (no
records, no GL); curve_shapes.py makes what the engine draws of them.

Every basis is evaluated on the CPU, all of a prim's curves at once in numpy: linear;
cubic bezier, bspline and catmullRom (each segment as its Bezier control points), with
the nonperiodic, periodic and pinned wraps (pinned adds UsdGeomBasisCurves' phantom
points, 2 P0 - P1 and 2 Pn-1 - Pn-2, so the curve starts and ends on its end points);
NurbsCurves of any order by Cox-de Boor over their knots, rational where pointWeights
are authored, each curve over its `ranges` (without order or knots: straight through
their control points, as Storm draws every NurbsCurves). Each cubic span is cut into straight
pieces until the polyline is within TOLERANCE of the prim's size from the curve (at
most MAX_PIECES a span). Widths (constant, uniform, vertex, varying; one value is
constant whatever its interpolation) and normals are interpolated as USD says: vertex
values by the curve's basis, varying ones linearly over each segment. Primvars reach
the samples from their nearest control vertex (`Polylines.source`) or their curve.

A curve with too few vertices for its basis and wrap is left out (`Polylines.skipped`
says so) and the others are kept, as Storm does; any other defect (counts that do not
add up, a primvar whose count fits no interpolation, a knot vector of the wrong
length) is a ValueError naming it, and the reader skips the prim with a warning."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import UsdGeom

from .validate import check_items

TOLERANCE = 2.5e-4             # polyline to curve, over the prim's bounding-box diagonal
MAX_PIECES = 64                # straight pieces per cubic span at most
DEFAULT_WIDTH = 1.0            # unauthored widths, as Storm


@dataclass
class Polylines:
    """The curves of a prim sampled: `points` (m, 3) with their `widths` (m,) and
    `normals` (m, 3) or None; drawn curve i is samples starts[i]:starts[i+1], closed
    (its last sample joins its first) where `closed[i]`. `source`: the control vertex
    nearest each sample; `curve`: each sample's curve (its index in the prim)."""
    points: np.ndarray
    widths: np.ndarray
    normals: np.ndarray | None
    starts: np.ndarray
    closed: np.ndarray
    source: np.ndarray
    curve: np.ndarray
    skipped: str | None = None     # curves left out (too few vertices for the basis)

    def segments(self) -> np.ndarray:
        """(s, 2) sample index pairs of the straight pieces, each curve's in order,
        closed curves' closing pieces last."""
        sizes = np.diff(self.starts)
        last = np.zeros(len(self.points), bool)
        last[self.starts[1:] - 1] = True
        inner = np.flatnonzero(~last)
        pairs = [np.stack([inner, inner + 1], axis=1)]
        closing = self.closed & (sizes > 2)
        pairs.append(np.stack([self.starts[1:][closing] - 1, self.starts[:-1][closing]], axis=1))
        return np.concatenate(pairs).astype(np.int64)

    def neighbours(self):
        """(previous, next) sample of each sample along its curve (itself at an open
        curve's ends)."""
        i = np.arange(len(self.points))
        first = np.zeros(len(i), bool)
        first[self.starts[:-1]] = True
        last = np.zeros(len(i), bool)
        last[self.starts[1:] - 1] = True
        curve_of = np.repeat(np.arange(len(self.closed)), np.diff(self.starts))
        closed = self.closed[curve_of]
        prev = np.where(first, np.where(closed, self.starts[1:][curve_of] - 1, i), i - 1)
        nxt = np.where(last, np.where(closed, self.starts[:-1][curve_of], i), i + 1)
        return prev, nxt


def has_normals(prim) -> bool:
    attr = UsdGeom.PointBased(prim).GetNormalsAttr()
    return bool(attr) and attr.HasAuthoredValue()


def _array(attr, time, dtype=np.float64):
    if not attr or not attr.HasValue():
        return None
    v = attr.Get(time)
    return None if v is None else np.asarray(v, dtype)


def finite(values, what):
    """ValueError naming how many values are not finite in float32 (validate.py)."""
    check_items(values, what)


# Cubic bases as Bezier control points of the segment on P0..P3 (rows: b0..b3); a
# linear segment on P0, P1 as a straight Bezier.
_TO_BEZIER = {
    "bezier": np.eye(4),
    "bspline": np.array([[1, 4, 1, 0], [0, 4, 2, 0], [0, 2, 4, 0], [0, 1, 4, 1]]) / 6.0,
    "catmullRom": np.array([[0, 6, 0, 0], [-1, 6, 1, 0], [0, 1, 6, -1], [0, 0, 6, 0]]) / 6.0,
    "linear": np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]]),
}
# The control vertices a segment runs between (for each sample's nearest one).
_ENDS = {"bezier": (0, 3), "bspline": (1, 2), "catmullRom": (1, 2), "linear": (0, 1)}


def _bernstein(u):
    v = 1.0 - u
    return np.stack([v * v * v, 3 * v * v * u, 3 * v * u * u, u * u * u], axis=-1)


def _spans(n, kind, basis, wrap):
    """Per curve of n vertices: (segments, closed, padded with phantom points, drawable,
    varying values), by USD's counting (varying: the nominal count where a curve has
    too few vertices)."""
    periodic = wrap == "periodic"
    if kind == "linear":
        closed = periodic & (n > 2)
        return np.where(closed, n, n - 1), closed, np.zeros_like(closed), n >= 2, n
    if basis == "bezier":
        if periodic:
            ok = (n >= 3) & (n % 3 == 0)
            return n // 3, ok, np.zeros_like(ok), ok, n // 3
        ok = (n >= 4) & ((n - 4) % 3 == 0)
        segments = np.maximum((n - 4) // 3 + 1, 0)
        return segments, np.zeros_like(ok), np.zeros_like(ok), ok, segments + 1
    if periodic:
        return n, n >= 3, np.zeros(len(n), bool), n >= 3, n
    if wrap == "pinned":
        return n - 1, np.zeros(len(n), bool), np.ones(len(n), bool), n >= 2, n
    return np.maximum(n - 3, 0), np.zeros(len(n), bool), np.zeros(len(n), bool), n >= 4, \
        np.maximum(n - 2, 0)


def _flat(values, interp, counts, varying, what):
    """(values per vertex, 'vertex') or (values per varying slot, 'varying') of a
    primvar, or ValueError."""
    if interp == "constant" or len(values) == 1:
        return np.repeat(values[:1], int(counts.sum()), axis=0), "vertex"
    if interp == "uniform" and len(values) == len(counts):
        return np.repeat(values, counts, axis=0), "vertex"
    if interp == "vertex" and len(values) == counts.sum():
        return values, "vertex"
    if interp in ("varying", "faceVarying") and len(values) == varying.sum():
        return values, "varying"
    if interp not in ("uniform", "vertex", "varying", "faceVarying"):
        raise ValueError(f"{what} has interpolation {interp}")
    wanted = {"uniform": len(counts), "vertex": counts.sum()}.get(interp, varying.sum())
    raise ValueError(f"{what} has {len(values)} {interp} values for {int(wanted)}")


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
    finite(values, "widths")
    if (values < 0).any():
        raise ValueError("negative widths")
    return _flat(values, interp, counts, varying, "widths")


def _normals(curves, time, counts, varying):
    a = curves.GetNormalsAttr()
    v = a.Get(time) if a and a.HasAuthoredValue() else None
    if v is None or not len(v):
        return None, None
    values = np.asarray(v, np.float64).reshape(-1, 3)
    finite(values, "normals")
    return _flat(values, str(curves.GetNormalsInterpolation()), counts, varying, "normals")


def _pieces(bez, tol):
    """Straight pieces per cubic span (Bezier control points (s, 4, 3)): the polyline
    of k pieces is within max|B''| / (8 k^2) of the curve."""
    second = np.maximum(np.linalg.norm(bez[:, 0] - 2 * bez[:, 1] + bez[:, 2], axis=1),
                        np.linalg.norm(bez[:, 1] - 2 * bez[:, 2] + bez[:, 3], axis=1))
    k = np.ceil(np.sqrt(6.0 * second / (8.0 * max(tol, 1e-30))))
    return np.clip(k, 1, MAX_PIECES).astype(np.int64)


def _pad(values, offsets, n, padded):
    """Per-vertex values with pinned curves' phantom values around each of them
    (2 v0 - v1 before, 2 vn-1 - vn-2 after; a curve of one vertex repeats it), and
    each control slot's offset per curve."""
    size = n + 2 * padded
    at = np.concatenate([[0], np.cumsum(size)])
    out = np.empty((int(at[-1]),) + values.shape[1:], values.dtype)
    real = np.arange(len(values)) + np.repeat(at[:-1] - offsets[:-1] + padded, n)
    out[real] = values
    first, last = offsets[:-1][padded], offsets[1:][padded] - 1
    second = np.minimum(first + 1, last)
    before = np.maximum(last - 1, first)
    out[at[:-1][padded]] = 2 * values[first] - values[second]
    out[at[1:][padded] - 1] = 2 * values[last] - values[before]
    return out, at


def basis_curves(prim, time, points=None, shape=None) -> Polylines:
    """The samples of a BasisCurves prim (of `points` in place of its own: skinned
    ones); ValueError naming a defect. `shape`: (type, basis, wrap) in place of the
    prim's own (a NurbsCurves prim drawn through its control points)."""
    curves = UsdGeom.Curves(prim)
    pts = _array(curves.GetPointsAttr(), time) if points is None else points
    counts = _array(curves.GetCurveVertexCountsAttr(), time, np.int64)
    if pts is None or counts is None or not len(pts) or not len(counts):
        raise ValueError("no points or curveVertexCounts")
    pts = pts.reshape(-1, 3)
    if (counts < 1).any() or counts.sum() != len(pts):
        raise ValueError(f"curveVertexCounts add up to {counts.sum()} for {len(pts)} points")
    finite(pts, "points")
    if shape is None:
        own = UsdGeom.BasisCurves(prim)
        shape = (own.GetTypeAttr().Get(time) or "cubic", own.GetBasisAttr().Get(time) or
                 "bezier", own.GetWrapAttr().Get(time) or "nonperiodic")
    kind, basis, wrap = shape
    if kind not in ("linear", "cubic") or basis not in _TO_BEZIER or basis == "linear" or \
            wrap not in ("nonperiodic", "periodic", "pinned"):
        raise ValueError(f"type {kind}, basis {basis}, wrap {wrap} is not one USD defines")
    if kind == "linear":
        basis = "linear"
    nseg, closed, padded, drawn, varying = _spans(counts, kind, basis, wrap)
    widths, w_interp = _widths(curves, time, counts, varying)
    normals, n_interp = _normals(curves, time, counts, varying)
    if not drawn.any():
        raise ValueError(_too_few(counts[0], kind, basis, wrap))
    offsets = np.concatenate([[0], np.cumsum(counts)])
    padded = padded & drawn
    control, at = _pad(pts, offsets, counts, padded)
    source, _ = _pad(np.arange(len(pts)), offsets, counts, padded)
    source = np.clip(source, offsets[:-1].repeat(counts + 2 * padded),
                     (offsets[1:] - 1).repeat(counts + 2 * padded))   # phantoms: their end

    # Every drawn curve's segments, and the control slots each reads.
    curve_of = np.repeat(np.flatnonzero(drawn), nseg[drawn])
    first_seg = np.concatenate([[0], np.cumsum(nseg[drawn])])[:-1]
    j = np.arange(len(curve_of)) - np.repeat(first_seg, nseg[drawn])
    step, width = (3, 4) if basis == "bezier" else (1, 2 if basis == "linear" else 4)
    local = j[:, None] * step + np.arange(width)[None]
    size = (counts + 2 * padded)[curve_of][:, None]
    local = np.where(closed[curve_of][:, None], local % size, local)
    slots = at[curve_of][:, None] + local
    m = _TO_BEZIER[basis]
    bez = np.einsum("ij,sjk->sik", m, control[slots])
    diagonal = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    k = np.ones(len(slots), np.int64) if basis == "linear" else \
        _pieces(bez, TOLERANCE * max(diagonal, 1e-30))

    # Samples: k a segment at u = i / k, and each open curve's end point.
    ends_open = (j == nseg[curve_of] - 1) & ~closed[curve_of]
    per_seg = k + ends_open
    seg = np.repeat(np.arange(len(slots)), per_seg)
    u = (np.arange(len(seg)) - np.repeat(np.cumsum(per_seg) - per_seg, per_seg)) / k[seg]
    points = np.einsum("mj,mjk->mk", _bernstein(u), bez[seg])

    def along(values, interp):
        if interp == "varying":
            var_at = np.concatenate([[0], np.cumsum(varying)])
            start = var_at[curve_of] + j
            end = var_at[curve_of] + (j + 1) % varying[curve_of]
            t = u.reshape((-1,) + (1,) * (values.ndim - 1))
            return values[start][seg] * (1 - t) + values[end][seg] * t
        v, _ = _pad(values, offsets, counts, padded)
        return np.einsum("mj,mj...->m...", _bernstein(u),
                         np.einsum("ij,sj...->si...", m, v[slots])[seg])

    a, b = _ENDS[basis]
    nearest = np.where(u < 0.5, slots[seg, a], slots[seg, b])
    lines = Polylines(points=points, widths=np.maximum(along(widths, w_interp), 0.0),
                      normals=None if normals is None else along(normals, n_interp),
                      starts=np.concatenate([[0], np.cumsum(np.bincount(
                          curve_of[seg], minlength=len(counts))[drawn])]).astype(np.int64),
                      closed=closed[drawn], source=source[nearest], curve=curve_of[seg])
    if not drawn.all():
        lines.skipped = (f"{int((~drawn).sum())} of {len(counts)} curves are not drawn "
                         f"({_too_few(counts[~drawn][0], kind, basis, wrap)})")
    return lines


def _too_few(n, kind, basis, wrap) -> str:
    """Why a curve of n vertices has no segment."""
    n = int(n)
    vertices = f"{n} vertex" if n == 1 else f"{n} vertices"
    if kind == "linear":
        return f"a linear curve of {vertices} (2 at least)"
    if basis == "bezier":
        need = "3 a segment" if wrap == "periodic" else "4, 7, 10, ..."
        return f"a {wrap} bezier curve of {vertices} ({need})"
    least = {"periodic": 3, "pinned": 2}.get(wrap, 4)
    return f"a {wrap} {basis} curve of {vertices} ({least} at least)"


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


def nurbs_curves(prim, time, points=None) -> Polylines:
    """The samples of a NurbsCurves prim (order, knots, ranges, pointWeights); widths
    and normals by vertex are weighted by the same basis functions. Without order or
    knots no curve is defined: straight lines through the control points, as Storm
    draws every NurbsCurves."""
    curves = UsdGeom.NurbsCurves(prim)
    order = _array(curves.GetOrderAttr(), time, np.int64)
    knots = _array(curves.GetKnotsAttr(), time)
    if order is None or knots is None or not len(order) or not len(knots):
        return basis_curves(prim, time, points, shape=("linear", "bezier", "nonperiodic"))
    pts = _array(curves.GetPointsAttr(), time) if points is None else points
    counts = _array(curves.GetCurveVertexCountsAttr(), time, np.int64)
    if pts is None or counts is None or not len(counts):
        raise ValueError("no points or curveVertexCounts")
    pts = pts.reshape(-1, 3)
    if (counts < 1).any() or counts.sum() != len(pts):
        raise ValueError(f"curveVertexCounts add up to {counts.sum()} for {len(pts)} points")
    if len(order) != len(counts) or (order < 2).any() or (order > counts).any():
        raise ValueError("an order per curve, from 2 to its vertex count, is needed")
    if len(knots) != int((counts + order).sum()):
        raise ValueError(f"{len(knots)} knots for {int((counts + order).sum())}")
    finite(pts, "points")
    finite(knots, "knots")
    weights = _array(curves.GetPointWeightsAttr(), time)
    if weights is not None and len(weights) != len(pts):
        weights = None
    ranges = _array(curves.GetRangesAttr(), time)
    varying = counts - order + 2
    widths, w_interp = _widths(curves, time, counts, varying)
    normals, n_interp = _normals(curves, time, counts, varying)
    w_at = np.concatenate([[0], np.cumsum(counts if w_interp == "vertex" else varying)])
    n_at = np.concatenate([[0], np.cumsum(counts if n_interp == "vertex" else varying)])
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
        def along(values, interp, starts):
            v = values[starts[i]:starts[i + 1]]
            if interp == "vertex":
                return basis @ v
            grid = np.linspace(lo, hi, len(v))          # varying: linear between span ends
            if v.ndim == 1:
                return np.interp(u, grid, v)
            return np.stack([np.interp(u, grid, v[:, d]) for d in range(v.shape[1])], axis=1)
        wv = along(widths, w_interp, w_at)
        nv = None if normals is None else along(normals, n_interp, n_at)
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


def polylines(prim, time, points=None) -> Polylines:
    """The samples of a curves prim, of `points` (skinned) in place of its own."""
    if prim.IsA(UsdGeom.NurbsCurves):
        return nurbs_curves(prim, time, points)
    return basis_curves(prim, time, points)
