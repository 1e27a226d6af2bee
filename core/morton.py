"""Morton codes: points ordered along a Z-order curve over their box, so that points
close in the order lie close in space. The light tree orders its lights by them
(engine/light_tree.py) and the ray tracer's BVH its triangles (engine/bvh.py, as
Karras 2012 builds a linear BVH)."""
from __future__ import annotations

import numpy as np

BITS = 10                    # bits an axis: 30-bit codes


def morton_codes(points: np.ndarray, lo=None, hi=None) -> np.ndarray:
    """(n,) uint64 codes of `points` (n, 3) quantised to BITS bits an axis over the box
    (lo, hi) (default: the points' own)."""
    points = np.asarray(points, np.float64)
    lo = points.min(axis=0) if lo is None else np.asarray(lo, np.float64)
    hi = points.max(axis=0) if hi is None else np.asarray(hi, np.float64)
    top = float((1 << BITS) - 1)
    q = np.clip((points - lo) / np.maximum(hi - lo, 1e-30) * top, 0.0, top).astype(np.uint64)
    code = np.zeros(len(points), np.uint64)
    for bit in range(BITS):
        for axis in range(3):
            code |= ((q[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return code


def morton_order(points: np.ndarray) -> np.ndarray:
    """Indices of `points` (n, 3) along the Morton curve over their box (stable)."""
    return np.argsort(morton_codes(points), kind="stable")
