"""Stage metadata and /Render/Settings."""
from pxr import Gf, Sdf, UsdGeom, UsdRender

RENDER_SETTINGS = "/Render/Settings"


def write_metadata(stage, settings, root_path):
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if settings.up_axis == "Z" else UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, settings.meters_per_unit)
    stage.SetFramesPerSecond(settings.fps)
    stage.SetTimeCodesPerSecond(settings.fps)
    stage.SetStartTimeCode(settings.frame_start)
    stage.SetEndTimeCode(settings.frame_end)
    stage.SetDefaultPrim(stage.GetPrimAtPath(root_path))


def write_render_settings(stage, settings, camera_path):
    UsdGeom.Scope.Define(stage, "/Render")
    rs = UsdRender.Settings.Define(stage, RENDER_SETTINGS)
    rs.CreateResolutionAttr(Gf.Vec2i(*settings.resolution))
    rs.CreatePixelAspectRatioAttr(settings.pixel_aspect)
    if camera_path is not None:
        rs.CreateCameraRel().SetTargets([camera_path])
    # Blender's colour management, which display images (PNG, GIF) are made with.
    prim = rs.GetPrim()
    prim.CreateAttribute("lantern:viewTransform", Sdf.ValueTypeNames.String,
                         custom=True).Set(settings.view_transform)
    if settings.look:
        prim.CreateAttribute("lantern:look", Sdf.ValueTypeNames.String,
                             custom=True).Set(settings.look)
    prim.CreateAttribute("lantern:exposure", Sdf.ValueTypeNames.Float,
                         custom=True).Set(settings.exposure)
    stage.SetMetadata("renderSettingsPrimPath", RENDER_SETTINGS)
    return rs
