"""A UsdGeom.Mesh with subdivisionScheme catmullClark -> its cage refined on the CPU, and
its points moved onto the limit surface (unless the stage says Use Limit Surface was off),
or its limit surface's patches for the GPU (and, for a skinned cage, the patches as
weighted sums of its points).

A Mesh that does not author its subdivisionScheme has the schema's fallback,
catmullClark: it is a subdivision surface (files from other tools often leave it
unauthored). The level is the exporter's `lantern:subdivisionRenderLevel`; without it
(a stage from elsewhere) DEFAULT_RENDER_LEVEL. A skinned cage is refined after its
skinning by the GPU only; on the CPU path it is drawn unrefined, with a warning.
"""
import numpy as np
from pxr import UsdGeom, UsdSkel

from ..bezier_patches import bezier_patches, patch_stencils
from ..subdivision import (MAX_SHARPNESS, cage, face_varying_cage, limit_points,
                           parent_faces, refine, refine_face_varying)

LEVEL_ATTR = "lantern:subdivisionRenderLevel"
LIMIT_ATTR = "lantern:subdivisionLimitSurface"   # written only when false
# Refinements before a cage becomes patches: extraordinary vertices are then apart and
# the patches around them small. At 2, Blender's level-5 limit points lie within
# 1.3e-3 of the bounding-box diagonal there (at 1: 4.5e-3), docs/subdivision.md.
PATCH_LEVELS = 2
# The render level of a catmullClark mesh without LEVEL_ATTR: Blender's Subdivision
# Surface's default Render level, the one Lantern's own stages mostly carry.
DEFAULT_RENDER_LEVEL = 2


def subdivision_level(prim, warnings):
    """Levels to refine `prim` by (0: draw the points as they are)."""
    # Get() answers the schema's fallback, catmullClark, where nothing is authored.
    scheme = UsdGeom.Mesh(prim).GetSubdivisionSchemeAttr().Get()
    if scheme == UsdGeom.Tokens.none:
        return 0
    if scheme != UsdGeom.Tokens.catmullClark:
        _warn(warnings, f"{prim.GetPath()}: subdivisionScheme {scheme} is not refined; "
                        "drawn as its cage")
        return 0
    level_attr = prim.GetAttribute(LEVEL_ATTR)
    if not level_attr or not level_attr.HasValue():
        return DEFAULT_RENDER_LEVEL
    return max(0, int(level_attr.Get()))


def skinned_cage_unrefined(prim, warnings, tessellate, patches) -> bool:
    """A skinned cage is refined only after its skinning, as the GPU's patches
    (`patches`: this mesh becomes them). Otherwise it is drawn as its cage, with a
    warning saying why; returns whether it is."""
    if patches or not prim.HasAPI(UsdSkel.BindingAPI):
        return False
    path = prim.GetPath()
    if tessellate and limit_surface(prim):
        _warn(warnings, f"{path}: a skinned subdivision cage whose materials need tangents, "
                        "a colour attribute or Generated coordinates is drawn as its cage")
    else:
        _warn(warnings, f"{path}: a skinned subdivision cage is refined only by GL 4.3's "
                        "tessellation, with Use Limit Surface; drawn as its cage")
    return True


def limit_surface(prim) -> bool:
    """The level's points belong on the limit surface (Blender's Use Limit Surface)."""
    attr = prim.GetAttribute(LIMIT_ATTR)
    return not (attr and attr.HasValue() and not attr.Get())


def _warn(warnings, message):
    if warnings is not None:
        warnings.append(message)


class RefinedCage:
    """The refined points and faces, and how to carry cage data onto them. With
    `patches`, the cage is refined only as far as its patches need (PATCH_LEVELS, and past
    any semi-sharp crease), and `self.patches` holds their Bezier control points: the limit
    surface for the GPU to tessellate (engine/bezier_patches.py)."""

    def __init__(self, mesh, pts, counts, idx, levels, time, patches=False):
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
        base = cage(pts, counts, idx, np.reshape(pairs, (-1, 2)), pair_sharp,
                    arr(mesh.GetCornerIndicesAttr(), np.int64),
                    arr(mesh.GetCornerSharpnessesAttr(), np.float64),
                    boundary or "edgeAndCorner")
        self.base, self.limit = base, limit_surface(mesh.GetPrim())
        # USD's fallback is cornersPlus1; Lantern's exporter always writes Blender's rule.
        self.uv_rule = mesh.GetFaceVaryingLinearInterpolationAttr().Get(time) or "cornersPlus1"
        self.patches = self.stencils = None
        if patches:
            finite = np.concatenate([base.edge_sharpness, base.vertex_sharpness])
            finite = finite[(finite > 0) & (finite < MAX_SHARPNESS)]
            levels = max(PATCH_LEVELS, int(np.ceil(finite.max())) if len(finite) else 0)
        self.cage_counts, self.levels = counts, levels
        refined = refine(base, levels)
        self.points, self.counts, self.indices = refined.points, refined.counts, refined.indices
        if patches:
            self.patches = bezier_patches(refined)
            if mesh.GetPrim().HasAPI(UsdSkel.BindingAPI):     # made again after each pose
                self.stencils = patch_stencils(base, levels)
        elif levels > 0 and self.limit:
            self.points = limit_points(refined)

    def face_varying(self, per_cage_corner):
        """Per-corner values (UVs) on the refined faces, by the mesh's
        faceVaryingLinearInterpolation (engine/subdivision.py face_varying_cage), on the
        limit surface as the points are."""
        if self.uv_rule == "all":
            return refine_face_varying(self.cage_counts, per_cage_corner, self.levels)
        fv = refine(face_varying_cage(self.base, per_cage_corner, self.uv_rule), self.levels)
        return (limit_points(fv) if self.limit and self.levels > 0 else fv.points)[fv.indices]

    def face_varying_patches(self, per_cage_corner):
        """(F, 16, d) Bezier control points of per-corner values over the patches: the
        channel's own patches, or for `all` its bilinear corners raised to bicubic."""
        if self.uv_rule == "all":
            corners = refine_face_varying(self.cage_counts, per_cage_corner, self.levels)
            c = corners.reshape(-1, 4, corners.shape[1])
            t = np.arange(4) / 3.0
            u, v = t[None, :, None], t[:, None, None]          # B[v][u]
            grid = ((1 - u) * (1 - v) * c[:, None, None, 0] + u * (1 - v) * c[:, None, None, 1]
                    + u * v * c[:, None, None, 2] + (1 - u) * v * c[:, None, None, 3])
            return grid.reshape(len(c), 16, -1)
        return bezier_patches(refine(face_varying_cage(self.base, per_cage_corner,
                                                       self.uv_rule), self.levels))

    def faces(self, cage_faces):
        parent = parent_faces(self.cage_counts, self.levels)
        return np.flatnonzero(np.isin(parent, cage_faces))
