"""CameraRecord -> UsdGeom.Camera on the object prim."""
from pxr import Gf, UsdGeom


def write_camera(stage, path, rec):
    cam = UsdGeom.Camera.Define(stage, path)
    cam.CreateProjectionAttr(rec.projection)
    cam.CreateFocalLengthAttr(rec.focal_length)
    cam.CreateHorizontalApertureAttr(rec.horizontal_aperture)
    cam.CreateVerticalApertureAttr(rec.vertical_aperture)
    cam.CreateHorizontalApertureOffsetAttr(rec.horizontal_offset)
    cam.CreateVerticalApertureOffsetAttr(rec.vertical_offset)
    cam.CreateClippingRangeAttr(Gf.Vec2f(rec.clip_start, rec.clip_end))
    return cam
