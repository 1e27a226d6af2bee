"""An evaluated Blender Curves object (hair) -> CurvesRecords, as Blender's own USD
exporter writes them (docs/stage_contract.md "Curves"): one record per curve type and
cyclic flag among its curves (a USD prim has one of each), widths twice the radius
(Blender's 0.01 where the data has none).

- Catmull-Rom: cubic catmullRom, `pinned` (Blender's Catmull-Rom passes through its
  end points, as USD's pinned wrap does) or `periodic`; vertex widths;
- Poly: linear, nonperiodic or periodic; vertex widths;
- Bezier: cubic bezier, the knots with their handles between them (knot, right
  handle, next left handle, next knot...), nonperiodic or periodic; widths per knot
  (varying: Blender interpolates the radius linearly between knots);
- NURBS: a cubic uniform one (order 4, Normal knots, weights 1: a uniform cubic
  B-spline) is cubic bspline, nonperiodic or periodic; others are NurbsCurves of
  their order with their weights and the knot vector Blender evaluates (uniform for
  Normal, clamped for Endpoint). A cyclic one of those, or another knot mode, is a
  warning, and those curves are left out."""
import numpy as np

from ..errors import require_finite
from ..ir import CurvesRecord
from .mesh import _get

DEFAULT_RADIUS = 0.01
TYPES = {0: "catmullRom", 1: "linear", 2: "bezier", 3: "nurbs"}   # Blender's curve_type
KNOTS_NORMAL, KNOTS_ENDPOINT = 0, 1


def _curve_attribute(data, name, default, dtype, n):
    attr = data.attributes.get(name)
    if attr is None or attr.domain != "CURVE" or len(attr.data) != n:
        return np.full(n, default, dtype)
    return _get(attr.data, "value", dtype, 1).reshape(n)


def _point_vectors(data, name, n):
    attr = data.attributes.get(name)
    if attr is None or len(attr.data) != n:
        return None
    return _get(attr.data, "vector", np.float32, 3).reshape(n, 3)


def gather_curves(data, name, owner, warn) -> list:
    """[CurvesRecord] of a Curves datablock (evaluated), in its object's space."""
    n_points, n_curves = len(data.points), len(data.curves)
    if not n_points or not n_curves:
        return []
    positions = _point_vectors(data, "position", n_points)
    offsets = _get(data.curve_offset_data, "value", np.int64, 1).reshape(-1)
    require_finite(positions, owner, "curve points")
    radius_attr = data.attributes.get("radius")
    if radius_attr is not None and len(radius_attr.data) == n_points:
        radii = _get(radius_attr.data, "value", np.float32, 1).reshape(n_points)
    else:
        radii = np.full(n_points, DEFAULT_RADIUS, np.float32)
    require_finite(radii, owner, "curve radii")
    kinds = _curve_attribute(data, "curve_type", 0, np.int64, n_curves)
    cyclic = _curve_attribute(data, "cyclic", False, bool, n_curves)
    records = []
    groups = sorted({(int(k), bool(c)) for k, c in zip(kinds, cyclic)})
    for kind, closed in groups:
        chosen = np.flatnonzero((kinds == kind) & (cyclic == closed))
        spans = [(int(offsets[i]), int(offsets[i + 1])) for i in chosen]
        label = TYPES.get(kind, "catmullRom")
        suffix = "" if len(groups) == 1 else f"_{label}{'_cyclic' if closed else ''}"
        if label == "bezier":
            rec = _bezier(data, positions, radii, spans, closed, n_points, owner)
        elif label == "nurbs":
            rec = _nurbs(data, positions, radii, spans, closed, chosen, n_curves, owner, warn)
        else:
            rec = CurvesRecord(
                name="", points=np.concatenate([positions[a:b] for a, b in spans]),
                counts=np.array([b - a for a, b in spans], np.int32),
                widths=2.0 * np.concatenate([radii[a:b] for a, b in spans]),
                kind="linear" if label == "linear" else "cubic",
                basis="catmullRom" if label == "catmullRom" else None,
                wrap="periodic" if closed else ("pinned" if label == "catmullRom" else "nonperiodic"))
        made = rec if isinstance(rec, list) else [rec]
        for one in made:
            # NURBS curves split into B-splines and NurbsCurves: a prim each.
            one.name = name + suffix + ("_nurbs" if len(made) > 1 and one.kind == "nurbs" else "")
            records.append(one)
    return records


def _bezier(data, positions, radii, spans, closed, n_points, owner):
    left = _point_vectors(data, "handle_left", n_points)
    right = _point_vectors(data, "handle_right", n_points)
    if left is None or right is None:       # no handles: each knot's are the knot itself
        left = right = positions
    require_finite(left, owner, "curve handles")
    require_finite(right, owner, "curve handles")
    points, counts, widths = [], [], []
    for a, b in spans:
        knots = []
        for i in range(a, b):
            if i > a:
                knots += [left[i]]
            knots += [positions[i], right[i]]
        if closed:
            knots += [left[a]]                   # the segment back to the first knot
        else:
            knots = knots[:-1]                   # no handle after the last knot
        points += knots
        counts.append(len(knots))
        widths.append(2.0 * radii[a:b])
    return CurvesRecord(name="", points=np.array(points, np.float32),
                        counts=np.array(counts, np.int32), widths=np.concatenate(widths),
                        kind="cubic", basis="bezier",
                        wrap="periodic" if closed else "nonperiodic",
                        widths_interpolation="varying")


def _nurbs(data, positions, radii, spans, closed, chosen, n_curves, owner, warn):
    """[CurvesRecord]: the uniform cubic B-splines among the curves, then the rest."""
    orders = _curve_attribute(data, "nurbs_order", 4, np.int64, n_curves)[chosen]
    modes = _curve_attribute(data, "knots_mode", KNOTS_NORMAL, np.int64, n_curves)[chosen]
    weight_attr = data.attributes.get("nurbs_weight")
    weights = _get(weight_attr.data, "value", np.float32, 1).reshape(-1) \
        if weight_attr is not None and len(weight_attr.data) == len(positions) else \
        np.ones(len(positions), np.float32)
    uniform = [j for j, ((a, b), o, m) in enumerate(zip(spans, orders, modes))
               if o == 4 and m == KNOTS_NORMAL and (weights[a:b] == 1).all() and
               b - a >= (3 if closed else 4)]
    general = [j for j, ((a, b), o, m) in enumerate(zip(spans, orders, modes))
               if j not in uniform and not closed and m in (KNOTS_NORMAL, KNOTS_ENDPOINT)
               and 2 <= o <= b - a]
    left_out = len(spans) - len(uniform) - len(general)
    if left_out:
        warn(f"{owner}: {left_out} NURBS curves are cyclic and not uniform cubic, have a "
             f"knot mode other than Normal or Endpoint, or fewer points than their order; "
             f"left out")
    records = []
    if uniform:
        records.append(CurvesRecord(
            name="", points=np.concatenate([positions[spans[j][0]:spans[j][1]] for j in uniform]),
            counts=np.array([spans[j][1] - spans[j][0] for j in uniform], np.int32),
            widths=2.0 * np.concatenate([radii[spans[j][0]:spans[j][1]] for j in uniform]),
            kind="cubic", basis="bspline", wrap="periodic" if closed else "nonperiodic"))
    if general:
        knots = []
        for j in general:
            a, b = spans[j]
            n, order = b - a, int(orders[j])
            if modes[j] == KNOTS_ENDPOINT:
                inner = np.arange(1, n - order + 1, dtype=np.float64)
                knots.append(np.concatenate([np.zeros(order), inner,
                                             np.full(order, n - order + 1.0)]))
            else:
                knots.append(np.arange(n + order, dtype=np.float64))
        take = lambda values: np.concatenate([values[spans[j][0]:spans[j][1]]  # noqa: E731
                                              for j in general])
        records.append(CurvesRecord(
            name="", points=take(positions),
            counts=np.array([spans[j][1] - spans[j][0] for j in general], np.int32),
            widths=2.0 * take(radii), kind="nurbs",
            orders=np.array([orders[j] for j in general], np.int32),
            knots=np.concatenate(knots), weights=take(weights)))
    return records
