"""A UsdGeom.Mesh with subdivisionScheme catmullClark -> its cage refined on the CPU, and
its points moved onto the limit surface (unless the stage says Use Limit Surface was off).

The level is the exporter's `lantern:subdivisionRenderLevel`; without it (a stage from
elsewhere) the cage is drawn, with a warning. Skinned cages are drawn unrefined (refining
after deformation is not built), with a warning.
"""
import numpy as np
from pxr import UsdGeom, UsdSkel

from ..subdivision import cage, limit_points, parent_faces, refine, refine_face_varying

LEVEL_ATTR = "lantern:subdivisionRenderLevel"
LIMIT_ATTR = "lantern:subdivisionLimitSurface"   # written only when false


def subdivision_level(prim, warnings):
    """Levels to refine `prim` by (0: draw the points as they are)."""
    mesh = UsdGeom.Mesh(prim)
    scheme = mesh.GetSubdivisionSchemeAttr()
    if not scheme.HasAuthoredValue() or scheme.Get() == UsdGeom.Tokens.none:
        return 0
    path = prim.GetPath()
    if scheme.Get() != UsdGeom.Tokens.catmullClark:
        _warn(warnings, f"{path}: subdivisionScheme {scheme.Get()} is not refined; "
                        "drawn as its cage")
        return 0
    level_attr = prim.GetAttribute(LEVEL_ATTR)
    if not level_attr or not level_attr.HasValue():
        _warn(warnings, f"{path}: subdivisionScheme catmullClark without {LEVEL_ATTR}; "
                        "drawn as its cage")
        return 0
    if prim.HasAPI(UsdSkel.BindingAPI):
        _warn(warnings, f"{path}: a skinned subdivision cage is not refined; drawn as its cage")
        return 0
    return max(0, int(level_attr.Get()))


def _warn(warnings, message):
    if warnings is not None:
        warnings.append(message)


class RefinedCage:
    """The refined points and faces, and how to carry cage data onto them."""

    def __init__(self, mesh, pts, counts, idx, levels, time):
        def arr(attr, dtype):
            v = attr.Get(time)
            return np.asarray(v, dtype) if v is not None else np.zeros(0, dtype)
        creases = arr(mesh.GetCreaseIndicesAttr(), np.int64)
        lengths = arr(mesh.GetCreaseLengthsAttr(), np.int64)
        sharp = arr(mesh.GetCreaseSharpnessesAttr(), np.float64)
        # A crease of length L is L-1 edges of one sharpness (or one per edge).
        pairs, pair_sharp, at = [], [], 0
        for i, n in enumerate(lengths):
            run = creases[at:at + n]
            s = sharp[i] if len(sharp) == len(lengths) else None
            for j in range(n - 1):
                pairs.append(run[j:j + 2])
                pair_sharp.append(s if s is not None else sharp[at - i + j])
            at += n
        boundary = mesh.GetInterpolateBoundaryAttr().Get(time)
        self.cage_counts, self.levels = counts, levels
        refined = refine(cage(pts, counts, idx, np.reshape(pairs, (-1, 2)), pair_sharp,
                              arr(mesh.GetCornerIndicesAttr(), np.int64),
                              arr(mesh.GetCornerSharpnessesAttr(), np.float64),
                              boundary or "edgeAndCorner"), levels)
        self.points, self.counts, self.indices = refined.points, refined.counts, refined.indices
        limit = mesh.GetPrim().GetAttribute(LIMIT_ATTR)
        if levels > 0 and not (limit and limit.HasValue() and not limit.Get()):
            self.points = limit_points(refined)

    def face_varying(self, per_cage_corner):
        return refine_face_varying(self.cage_counts, per_cage_corner, self.levels)

    def faces(self, cage_faces):
        parent = parent_faces(self.cage_counts, self.levels)
        return np.flatnonzero(np.isin(parent, cage_faces))
