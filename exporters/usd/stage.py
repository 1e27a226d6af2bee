"""Stage metadata, /Render/Settings and the view layer's RenderProduct."""
from pxr import Gf, Sdf, Tf, UsdGeom, UsdRender

from ...core.passes import PASSES, options

RENDER_SETTINGS = "/Render/Settings"
PRODUCTS = "/Render/Products"
VARS = "/Render/Vars"
# A RenderVar's dataType by its pass's channels.
DATA_TYPES = {1: "float", 3: "color3f", 4: "color4f"}


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
    # Cycles' Light Paths, which the engine's bounced light follows.
    for name, value in (("lantern:maxBounces", settings.max_bounces),
                        ("lantern:diffuseBounces", settings.diffuse_bounces),
                        ("lantern:glossyBounces", settings.glossy_bounces)):
        prim.CreateAttribute(name, Sdf.ValueTypeNames.Int, custom=True).Set(int(value))
    if settings.render_passes:
        write_render_product(stage, rs, settings)
    stage.SetMetadata("renderSettingsPrimPath", RENDER_SETTINGS)
    return rs


def write_render_product(stage, rs, settings):
    """One RenderProduct of the view layer's passes, as `lantern render` reads it: the
    Combined image (Hydra's `color`) and a RenderVar per pass, by the command line's
    names (core/passes.py options; a Cryptomatte's levels are one var)."""
    UsdGeom.Scope.Define(stage, PRODUCTS)
    UsdGeom.Scope.Define(stage, VARS)
    product = UsdRender.Product.Define(
        stage, f"{PRODUCTS}/{Tf.MakeValidIdentifier(settings.view_layer)}")
    product.CreateProductNameAttr(settings.output)
    product.GetPrim().CreateAttribute("lantern:viewLayer", Sdf.ValueTypeNames.String,
                                      custom=True).Set(settings.view_layer)
    wanted = set(settings.render_passes)
    sources = [("color", 4)] + [(option, PASSES[names[0]].channels)
                                for option, names in options().items() if wanted & set(names)]
    targets = []
    for source, channels in sources:
        var = UsdRender.Var.Define(stage, f"{VARS}/{source}")
        var.CreateSourceNameAttr(source)
        var.CreateSourceTypeAttr(UsdRender.Tokens.raw)
        var.CreateDataTypeAttr("normal3f" if source == "normal" else DATA_TYPES[channels])
        targets.append(var.GetPath())
    product.CreateOrderedVarsRel().SetTargets(targets)
    rs.CreateProductsRel().SetTargets([product.GetPath()])
