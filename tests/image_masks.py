"""Silhouettes of rendered images: coverage masks and how far two masks' outlines lie
from each other, in pixels."""
import numpy as np


def coverage_mask(rgba, threshold=0.5):
    """Pixels at least `threshold` covered (alpha of a render over a transparent film)."""
    return np.asarray(rgba)[..., 3] >= threshold


def outline(mask):
    """The mask's pixels with a 4-neighbour outside it (the image border is outside)."""
    padded = np.pad(mask, 1, constant_values=False)
    inner = padded[1:-1, 1:-1] & padded[:-2, 1:-1] & padded[2:, 1:-1] & \
        padded[1:-1, :-2] & padded[1:-1, 2:]
    return mask & ~inner


def silhouette_distance(a, b) -> float:
    """The symmetric Hausdorff distance between two masks' outlines, in pixels of the
    8-neighbourhood (chessboard): every outline pixel of one lies within it of the
    other's outline (0: the same; 1: on it or next to it)."""
    from scipy.ndimage import distance_transform_cdt
    oa, ob = outline(a), outline(b)
    if not oa.any() and not ob.any():
        return 0.0
    if not oa.any() or not ob.any():
        return float("inf")
    to_b = distance_transform_cdt(~ob, metric="chessboard")
    to_a = distance_transform_cdt(~oa, metric="chessboard")
    return float(max(to_b[oa].max(), to_a[ob].max()))


def over(rgba, background):
    """Premultiplied RGBA over a constant background colour -> RGB."""
    rgba = np.asarray(rgba, np.float64)
    return rgba[..., :3] + (1.0 - rgba[..., 3:4]) * np.asarray(background, np.float64)
