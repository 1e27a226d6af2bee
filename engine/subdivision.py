"""Uniform Catmull-Clark refinement of a polygon cage on the CPU, with creases and corners.

The rules are OpenSubdiv's Catmark scheme with the uniform crease method (USD's and
Blender's): an edge of sharpness s >= 1 is split at its midpoint, 0 < s < 1 blends the
smooth and sharp edge points by s, and each level lowers every sharpness by 1
(MAX_SHARPNESS stays infinite). Open and non-manifold edges are infinitely sharp
(interpolateBoundary edgeOnly / edgeAndCorner). Child vertices are numbered as
OpenSubdiv and Blender number them: parent vertices, then one per edge, then one per face.

`limit_points` then moves a refined mesh's points onto the limit surface, as Blender's
modifier does with Use Limit Surface (its default) and as USD means a catmullClark mesh.
"""
from dataclasses import dataclass

import numpy as np

MAX_SHARPNESS = 10.0  # infinitely sharp, as in USD and OpenSubdiv


@dataclass
class Cage:
    points: np.ndarray         # (N, 3) float64
    counts: np.ndarray         # (F,) int64
    indices: np.ndarray        # (C,) int64
    edges: np.ndarray          # (E, 2) int64, sorted pairs: edge sharpness is per pair
    edge_sharpness: np.ndarray  # (E,) float64
    vertex_sharpness: np.ndarray  # (N,) float64
    corners_sharp: bool = False  # interpolateBoundary edgeAndCorner
    # (C,) int64: each corner's edge (corner i to the next in its face), an index into
    # `edges` where `edges` came from the same _edges; None until topology() needs it.
    corner_edge: np.ndarray | None = None


def topology(c: Cage):
    """(edges, corner_edge) of `c`: found once per cage, as refinement, the vertex
    rules, the limit points and the patches all ask for them. A cage's edges are its
    faces' sorted pairs in _edges' order (edge_sharpness is aligned with them)."""
    if c.corner_edge is None:
        _, c.corner_edge = _edges(c.counts, c.indices)
    return c.edges, c.corner_edge


def cage(points, counts, indices, crease_pairs=(), crease_sharpness=(), corner_indices=(),
         corner_sharpness=(), interpolate_boundary="edgeOnly"):
    """A Cage from USD-style arrays (creases as vertex pairs)."""
    points = np.asarray(points, np.float64)
    counts, indices = np.asarray(counts, np.int64), np.asarray(indices, np.int64)
    edges, corner_edge = _edges(counts, indices)
    sharp = np.zeros(len(edges))
    pairs = np.sort(np.asarray(crease_pairs, np.int64).reshape(-1, 2), axis=1)
    if len(pairs):
        lookup = {tuple(e): i for i, e in enumerate(edges.tolist())}
        for pair, s in zip(pairs.tolist(), np.asarray(crease_sharpness, np.float64)):
            i = lookup.get(tuple(pair))
            if i is not None:
                sharp[i] = max(sharp[i], s)
    vsharp = np.zeros(len(points))
    vsharp[np.asarray(corner_indices, np.int64)] = np.asarray(corner_sharpness, np.float64)
    return Cage(points, counts, indices, edges, sharp, vsharp,
                corners_sharp=interpolate_boundary == "edgeAndCorner", corner_edge=corner_edge)


def _edges(counts, indices):
    """Unique sorted edges, and the edge of each corner (corner i to the next in its face)."""
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    local = np.arange(len(indices)) - starts
    nxt = indices[starts + (local + 1) % np.repeat(counts, counts)]
    pairs = np.sort(np.stack([indices, nxt], axis=1), axis=1)
    # One int64 key per pair: np.unique of rows (axis=0) sorts them as bytes, 100 times
    # slower. The keys sort as the pairs do, lexicographically.
    n = np.int64(max(int(indices.max(initial=0)) + 1, 1))
    keys, corner_edge = np.unique(pairs[:, 0] * n + pairs[:, 1], return_inverse=True)
    edges = np.stack([keys // n, keys % n], axis=1)
    return edges, corner_edge.reshape(-1)


def refine(c: Cage, levels: int) -> Cage:
    for _ in range(levels):
        c = refine_once(c)
    return c


def refine_once(c: Cage) -> Cage:
    n_v, n_f = len(c.points), len(c.counts)
    d = c.points.shape[1]       # 3, or any width: the rules are linear in the points
    edges, corner_edge = topology(c)
    n_e = len(edges)
    corner_face = np.repeat(np.arange(n_f), c.counts)
    face_points = np.zeros((n_f, d))
    np.add.at(face_points, corner_face, c.points[c.indices])
    face_points /= c.counts[:, None]

    edge_faces = np.bincount(corner_edge, minlength=n_e)
    sharp = c.edge_sharpness.copy()
    sharp[edge_faces != 2] = MAX_SHARPNESS  # open and non-manifold edges

    # Edge points.
    mid = 0.5 * (c.points[edges[:, 0]] + c.points[edges[:, 1]])
    face_sum = np.zeros((n_e, d))
    np.add.at(face_sum, corner_edge, face_points[corner_face])
    smooth = (c.points[edges[:, 0]] + c.points[edges[:, 1]] + face_sum) / \
        (2 + edge_faces)[:, None]
    t = np.clip(sharp, 0.0, 1.0)[:, None]
    edge_points = smooth * (1 - t) + mid * t

    # Vertex points: smooth rule, then crease and corner rules, blended where sharpness
    # runs out at this level (the parent's rule weighs by the mean vanishing sharpness).
    valence = np.bincount(edges.ravel(), minlength=n_v).astype(np.float64)
    faces_at = np.bincount(c.indices, minlength=n_v).astype(np.float64)
    q = np.zeros((n_v, d))
    np.add.at(q, c.indices, face_points[corner_face])
    r = np.zeros((n_v, d))
    np.add.at(r, edges[:, 0], mid)
    np.add.at(r, edges[:, 1], mid)
    with np.errstate(invalid="ignore", divide="ignore"):
        q /= np.maximum(faces_at, 1)[:, None]
        r /= np.maximum(valence, 1)[:, None]
        n = valence[:, None]
        smooth_v = (q + 2 * r + (n - 3) * c.points) / np.maximum(n, 1)

    is_sharp = sharp > 0
    sharp_count = np.zeros(n_v)
    np.add.at(sharp_count, edges[is_sharp].ravel(), 1)
    crease_sum = np.zeros((n_v, d))
    np.add.at(crease_sum, edges[is_sharp, 0], c.points[edges[is_sharp, 1]])
    np.add.at(crease_sum, edges[is_sharp, 1], c.points[edges[is_sharp, 0]])
    crease_v = (crease_sum + 6 * c.points) / 8

    vsharp = c.vertex_sharpness.copy()
    if c.corners_sharp:
        # A boundary vertex on a single face is a corner.
        open_edges = edges[edge_faces == 1]
        open_count = np.bincount(open_edges.ravel(), minlength=n_v)
        vsharp[(open_count == 2) & (faces_at == 1)] = MAX_SHARPNESS

    def rule(count, vs):  # 0 smooth/dart, 1 crease, 2 corner
        return np.where((vs > 0) | (count > 2), 2, np.where(count == 2, 1, 0))

    parent_rule = rule(sharp_count, vsharp)
    child_sharp = _lower(sharp)
    child_count = np.zeros(n_v)
    np.add.at(child_count, edges[child_sharp > 0].ravel(), 1)
    child_vsharp = _lower(vsharp)
    child_rule = rule(child_count, child_vsharp)

    by_rule = np.stack([smooth_v, crease_v, c.points])
    idx = np.arange(n_v)
    parent_pos, child_pos = by_rule[parent_rule, idx], by_rule[child_rule, idx]
    # Fraction: mean parent sharpness of what vanishes at this level (edges and vertex).
    vanishing = is_sharp & (child_sharp <= 0)
    frac_sum, frac_n = np.zeros(n_v), np.zeros(n_v)
    for end in (0, 1):
        np.add.at(frac_sum, edges[vanishing, end], sharp[vanishing])
        np.add.at(frac_n, edges[vanishing, end], 1)
    v_vanish = (vsharp > 0) & (child_vsharp <= 0)
    frac_sum += np.where(v_vanish, vsharp, 0)
    frac_n += v_vanish
    frac = np.where(frac_n > 0, frac_sum / np.maximum(frac_n, 1), 0.0)[:, None]
    vertex_points = np.where((parent_rule != child_rule)[:, None],
                             parent_pos * frac + child_pos * (1 - frac), parent_pos)

    points = np.concatenate([vertex_points, edge_points, face_points])

    # Child quads: (vertex, its outgoing edge, face, its incoming edge).
    starts = np.repeat(np.cumsum(c.counts) - c.counts, c.counts)
    local = np.arange(len(c.indices)) - starts
    prev_corner = starts + (local - 1) % np.repeat(c.counts, c.counts)
    quads = np.stack([c.indices, n_v + corner_edge, n_v + n_e + corner_face,
                      n_v + corner_edge[prev_corner]], axis=1)

    # Child edges: halves of each parent edge keep its (lowered) sharpness.
    halves = np.concatenate([np.stack([edges[:, 0], n_v + np.arange(n_e)], 1),
                             np.stack([edges[:, 1], n_v + np.arange(n_e)], 1)])
    child = Cage(points, np.full(len(quads), 4, np.int64), quads.reshape(-1),
                 np.zeros((0, 2), np.int64), np.zeros(0), np.zeros(len(points)),
                 corners_sharp=c.corners_sharp)
    child.vertex_sharpness[:n_v] = child_vsharp
    child_edges, child.corner_edge = _edges(child.counts, child.indices)
    child.edges = child_edges
    child.edge_sharpness = np.zeros(len(child_edges))
    keep = np.concatenate([c.edge_sharpness, c.edge_sharpness]) > 0
    if keep.any():
        lookup = {tuple(e): i for i, e in enumerate(child_edges.tolist())}
        hs = np.sort(halves[keep], axis=1)
        vals = _lower(np.concatenate([c.edge_sharpness, c.edge_sharpness])[keep])
        for pair, s in zip(hs.tolist(), vals):
            child.edge_sharpness[lookup[tuple(pair)]] = s
    return child


def vertex_rules(c: Cage):
    """Each point's rule on `c` as it stands (no more refinement): 0 smooth (or a dart,
    one sharp edge), 1 crease (two sharp edges: open boundaries included), 2 corner
    (more, a vertex sharpness, or a single-face boundary vertex under edgeAndCorner).
    Remaining semi-sharp sharpness counts as sharp, as OpenSubdiv's limit masks do.
    Also returns the edges and which of them are sharp."""
    n_v = len(c.points)
    edges, corner_edge = topology(c)
    edge_faces = np.bincount(corner_edge, minlength=len(edges))
    sharp = (c.edge_sharpness > 0) | (edge_faces != 2)
    count = np.bincount(edges[sharp].ravel(), minlength=n_v)
    corner = (c.vertex_sharpness > 0) | (count > 2)
    if c.corners_sharp:
        faces_at = np.bincount(c.indices, minlength=n_v)
        open_count = np.bincount(edges[edge_faces == 1].ravel(), minlength=n_v)
        corner |= (open_count == 2) & (faces_at == 1)
    return np.where(corner, 2, np.where(count == 2, 1, 0)), edges, sharp


def limit_points(c: Cage) -> np.ndarray:
    """The limit positions of an all-quad mesh's points (any level >= 1): smooth points
    (n^2 v + 4 sum(edge neighbours) + sum(diagonals)) / (n (n + 5)), crease points the
    cubic B-spline's (b0 + 4 v + b1) / 6 along their two sharp edges, corners fixed."""
    if (c.counts != 4).any():
        raise ValueError("limit_points needs an all-quad mesh (refine once first)")
    n_v, d = c.points.shape
    finite = np.concatenate([c.edge_sharpness, c.vertex_sharpness])
    finite = finite[(finite > 0) & (finite < MAX_SHARPNESS)]
    if len(finite):
        # Semi-sharp features shape the surface for ceil(s) more levels: refine past
        # them. A point's child keeps its number, and converges to the same limit.
        return limit_points(refine(c, int(np.ceil(finite.max()))))[:n_v]
    p = c.points
    rule, edges, sharp = vertex_rules(c)
    quads = c.indices.reshape(-1, 4)
    valence = np.bincount(edges.ravel(), minlength=n_v).astype(np.float64)
    e_sum = np.zeros((n_v, d))
    np.add.at(e_sum, edges[:, 0], p[edges[:, 1]])
    np.add.at(e_sum, edges[:, 1], p[edges[:, 0]])
    f_sum = np.zeros((n_v, d))
    for i in range(4):
        np.add.at(f_sum, quads[:, i], p[quads[:, (i + 2) % 4]])
    n = np.maximum(valence, 1)[:, None]
    smooth = (n * n * p + 4 * e_sum + f_sum) / (n * (n + 5))
    b_sum = np.zeros((n_v, d))
    np.add.at(b_sum, edges[sharp, 0], p[edges[sharp, 1]])
    np.add.at(b_sum, edges[sharp, 1], p[edges[sharp, 0]])
    crease = (b_sum + 4 * p) / 6
    return np.where((rule == 0)[:, None], smooth, np.where((rule == 1)[:, None], crease, p))


def _lower(s):
    return np.where(s >= MAX_SHARPNESS, MAX_SHARPNESS, np.maximum(s - 1.0, 0.0))


def refine_face_varying(counts, values, levels):
    """Per-corner values (UVs) over `levels` refinements, linearly within each face
    (faceVaryingLinearInterpolation `all`); corners in the refined faces' order."""
    counts = np.asarray(counts, np.int64)
    values = np.asarray(values, np.float64)
    for _ in range(levels):
        starts = np.repeat(np.cumsum(counts) - counts, counts)
        local = np.arange(len(values)) - starts
        per_face = np.repeat(counts, counts)
        nxt = values[starts + (local + 1) % per_face]
        prv = values[starts + (local - 1) % per_face]
        centre = np.zeros((len(counts), values.shape[1]))
        np.add.at(centre, np.repeat(np.arange(len(counts)), counts), values)
        centre = (centre / counts[:, None])[np.repeat(np.arange(len(counts)), counts)]
        values = np.stack([values, 0.5 * (values + nxt), centre, 0.5 * (values + prv)],
                          axis=1).reshape(-1, values.shape[1])
        counts = np.full(len(starts), 4, np.int64)
    return values


def parent_faces(counts, levels):
    """The cage face of each refined face."""
    counts = np.asarray(counts, np.int64)
    parent = np.arange(len(counts))
    for level in range(levels):
        parent = np.repeat(parent, counts if level == 0 else 4)
        counts = np.full(len(parent), 4, np.int64)
    return parent


def face_varying_cage(c: Cage, values, rule: str) -> Cage:
    """The cage of a face-varying channel (UVs): a point per distinct (point, value), the
    same faces, the mesh's creases on the edges they lie on, and USD's
    faceVaryingLinearInterpolation rule as sharpness where the channel's own
    boundaries are (its seams and the mesh's open edges). Refined like positions, it
    smooths the channel as OpenSubdiv does:
      none           smooth everywhere, boundaries as B-spline curves
      cornersOnly    and a boundary point of one face keeps its value
      cornersPlus1   and so does one where three or more of the channel's regions meet
      cornersPlus2   as cornersPlus1 (concave corners are not told apart)
      boundaries     every boundary point keeps its value: linear along boundaries
    ("all", linear everywhere, is refine_face_varying.)"""
    values = np.asarray(values, np.float64)
    key = np.concatenate([c.indices[:, None].astype(np.float64), values], axis=1)
    unique, fv_index = np.unique(key, axis=0, return_inverse=True)
    fv_index = fv_index.reshape(-1)
    point_of = unique[:, 0].astype(np.int64)
    fv = cage(unique[:, 1:], c.counts, fv_index, interpolate_boundary="edgeOnly")
    # The mesh's creases, on the channel's edges between the same two points.
    if (c.edge_sharpness > 0).any():
        lookup = {tuple(e): s for e, s in zip(c.edges.tolist(), c.edge_sharpness.tolist()) if s > 0}
        ends = np.sort(point_of[fv.edges], axis=1)
        fv.edge_sharpness = np.array([lookup.get(tuple(e), 0.0) for e in ends.tolist()])
    fv.vertex_sharpness = c.vertex_sharpness[point_of].copy()
    edges, corner_edge = topology(fv)
    open_edges = edges[np.bincount(corner_edge, minlength=len(edges)) == 1]
    on_boundary = np.zeros(len(unique), bool)
    on_boundary[open_edges.ravel()] = True
    sharp = np.zeros(len(unique), bool)
    if rule == "boundaries":
        sharp = on_boundary
    elif rule in ("cornersOnly", "cornersPlus1", "cornersPlus2"):
        faces_at = np.bincount(fv.indices, minlength=len(unique))
        sharp = on_boundary & (faces_at == 1)
        if rule != "cornersOnly":
            regions = np.bincount(point_of, minlength=len(c.points))[point_of]
            sharp |= on_boundary & (regions >= 3)
    elif rule != "none":
        raise ValueError(f"faceVaryingLinearInterpolation {rule!r} is not a smooth rule")
    fv.vertex_sharpness[sharp] = MAX_SHARPNESS
    return fv
