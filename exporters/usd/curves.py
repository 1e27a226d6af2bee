"""CurvesRecord -> UsdGeom.BasisCurves or UsdGeom.NurbsCurves with its widths, extent
and the object's first material (docs/stage_contract.md "Curves"), as Blender's own
USD exporter writes hair."""
import numpy as np
from pxr import Sdf, UsdGeom, UsdShade, Vt

from .mesh import DEFAULT_SURFACE_COLOR
from .names import set_blender_name


def write_curves(stage, path, rec, material_path=None):
    if rec.kind == "nurbs":
        curves = UsdGeom.NurbsCurves.Define(stage, path)
        curves.CreateOrderAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(rec.orders)))
        curves.CreateKnotsAttr(Vt.DoubleArray.FromNumpy(np.ascontiguousarray(rec.knots)))
        curves.CreatePointWeightsAttr(Vt.DoubleArray.FromNumpy(
            np.ascontiguousarray(rec.weights, np.float64)))
    else:
        curves = UsdGeom.BasisCurves.Define(stage, path)
        curves.CreateTypeAttr(rec.kind)
        if rec.basis is not None:
            curves.CreateBasisAttr(rec.basis)
        curves.CreateWrapAttr(rec.wrap)
    curves.CreateCurveVertexCountsAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(rec.counts)))
    curves.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rec.points)))
    curves.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.ascontiguousarray(rec.widths)))
    curves.SetWidthsInterpolation(rec.widths_interpolation)
    curves.CreateDoubleSidedAttr(True)
    half = float(rec.widths.max()) / 2 if len(rec.widths) else 0.0
    lo, hi = rec.points.min(axis=0) - half, rec.points.max(axis=0) + half
    curves.CreateExtentAttr(Vt.Vec3fArray([tuple(map(float, lo)), tuple(map(float, hi))]))
    set_blender_name(curves.GetPrim(), rec.name)
    if material_path is not None:
        UsdShade.MaterialBindingAPI.Apply(curves.GetPrim()).Bind(
            UsdShade.Material(stage.GetPrimAtPath(Sdf.Path(material_path))))
    else:                                    # Blender's default surface, as meshes get
        curves.CreateDisplayColorAttr(Vt.Vec3fArray([DEFAULT_SURFACE_COLOR]))
    return curves
