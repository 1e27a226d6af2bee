"""Lights per the contract's table, and the scene camera."""
import math

import bpy
import pytest
from pxr import UsdGeom, UsdLux, UsdRender

from _export_helpers import export_current


def add_light(name, kind, **props):
    light = bpy.data.lights.new(name, kind)
    for key, value in props.items():
        setattr(light, key, value)
    ob = bpy.data.objects.new(name, light)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def attr(prim, name):
    return prim.GetAttribute(name).Get()


def test_lights_follow_the_contract_table(empty_scene):
    add_light("Point", "POINT", energy=100.0, shadow_soft_size=0.2, use_shadow=False,
              use_soft_falloff=False, color=(1.0, 0.5, 0.25))
    add_light("Spot", "SPOT", energy=50.0, shadow_soft_size=0.0, spot_size=1.0, spot_blend=0.3)
    add_light("Sun", "SUN", energy=3.0, angle=0.1)
    add_light("Rect", "AREA", energy=20.0, shape="RECTANGLE", size=2.0, size_y=1.0)
    add_light("Disk", "AREA", energy=20.0, shape="DISK", size=1.5)
    stage, report = export_current()
    assert report.counts["lights"] == 5

    point = stage.GetPrimAtPath("/root/Point")
    assert point.IsA(UsdLux.SphereLight)
    assert attr(point, "inputs:intensity") == pytest.approx(100.0 / math.pi)
    assert attr(point, "inputs:radius") == pytest.approx(0.2)
    assert attr(point, "treatAsPoint") is False
    assert attr(point, "inputs:normalize") is True
    assert attr(point, "inputs:shadow:enable") is False
    assert point.HasAPI(UsdLux.ShadowAPI)
    assert attr(point, "lantern:softFalloff") is False
    assert tuple(attr(point, "inputs:color")) == pytest.approx((1.0, 0.5, 0.25))

    spot = stage.GetPrimAtPath("/root/Spot")
    assert spot.IsA(UsdLux.SphereLight) and spot.HasAPI(UsdLux.ShapingAPI)
    assert attr(spot, "inputs:intensity") == pytest.approx(50.0 / math.pi)
    assert attr(spot, "inputs:shaping:cone:angle") == pytest.approx(math.degrees(0.5), rel=1e-6)
    assert attr(spot, "inputs:shaping:cone:softness") == pytest.approx(0.3)
    assert attr(spot, "treatAsPoint") is True
    assert attr(spot, "inputs:shadow:enable") is True

    sun = stage.GetPrimAtPath("/root/Sun")
    assert sun.IsA(UsdLux.DistantLight)
    assert attr(sun, "inputs:intensity") == pytest.approx(3.0)
    assert attr(sun, "inputs:angle") == pytest.approx(math.degrees(0.1), rel=1e-6)

    rect = stage.GetPrimAtPath("/root/Rect")
    assert rect.IsA(UsdLux.RectLight)
    assert (attr(rect, "inputs:width"), attr(rect, "inputs:height")) == (2.0, 1.0)
    assert attr(rect, "inputs:intensity") == pytest.approx(20.0 / math.pi)

    disk = stage.GetPrimAtPath("/root/Disk")
    assert disk.IsA(UsdLux.DiskLight)
    assert attr(disk, "inputs:radius") == pytest.approx(0.75)
    assert not disk.GetAttribute("xformOp:scale:ellipse").IsValid()


def test_an_ellipse_is_a_disk_stretched_by_its_xform_and_read_back_as_the_ellipse(empty_scene):
    """Blender's Ellipse area light: a DiskLight of radius size_x / 2 with a scale op
    (1, size_y / size_x, 1) after the object's transform (docs/stage_contract.md); the
    engine reads it back as the ellipse, the object's own scale included, its radiance
    the power over the ellipse's area."""
    import numpy as np
    from lantern.core.lights import DISK
    from lantern.engine.lighting import light_area
    from lantern.engine.usd.stage import StageReader
    ob = add_light("Ellipse", "AREA", energy=40.0, shape="ELLIPSE", size=2.0, size_y=0.5)
    ob.rotation_euler = (0.0, 0.0, math.radians(30.0))
    ob.scale = (1.5, 1.0, 1.0)
    ob.location = (1.0, 2.0, 3.0)
    stage, report = export_current()
    assert not any("ellipse" in w for w in report.warnings), report.warnings
    prim = stage.GetPrimAtPath("/root/Ellipse")
    assert prim.IsA(UsdLux.DiskLight)
    assert attr(prim, "inputs:radius") == pytest.approx(1.0)
    assert tuple(attr(prim, "xformOp:scale:ellipse")) == pytest.approx((1.0, 0.25, 1.0))
    assert UsdGeom.Xformable(prim).GetXformOpOrderAttr().Get()[-1] == "xformOp:scale:ellipse"

    reader = StageReader(stage)
    reader.sync(None)
    light = reader.scene.lights["/root/Ellipse"]
    assert light.kind == DISK
    assert (light.width, light.height) == pytest.approx((3.0, 0.5))
    assert light.radius == pytest.approx(1.5)
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    np.testing.assert_allclose(light.x_axis, (c, s, 0.0), atol=1e-6)
    np.testing.assert_allclose(light.y_axis, (-s, c, 0.0), atol=1e-6)
    np.testing.assert_allclose(light.position, (1.0, 2.0, 3.0), atol=1e-6)
    area = math.pi * 1.5 * 0.25
    assert light_area(light) == pytest.approx(area)
    # Blender's power P spread over the ellipse: radiance P / (pi area) (normalized).
    np.testing.assert_allclose(light.color, 40.0 / (math.pi * area), rtol=1e-5)


def add_camera(**props):
    cam = bpy.data.cameras.new("Cam")
    for key, value in props.items():
        setattr(cam, key, value)
    ob = bpy.data.objects.new("Cam", cam)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.scene.camera = ob
    return ob


def set_resolution(x, y, pct=100):
    r = bpy.context.scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = x, y, pct


def test_camera_16_9_auto_fit(empty_scene):
    add_camera(lens=50.0, sensor_width=36.0, sensor_fit="AUTO", clip_start=0.5,
               clip_end=200.0, shift_x=0.1)
    set_resolution(1920, 1080, 50)
    stage, report = export_current()
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/root/Cam"))
    assert cam and report.counts["cameras"] == 1
    assert cam.GetProjectionAttr().Get() == "perspective"
    assert cam.GetFocalLengthAttr().Get() == pytest.approx(50.0)
    assert cam.GetHorizontalApertureAttr().Get() == pytest.approx(36.0)
    assert cam.GetVerticalApertureAttr().Get() == pytest.approx(36.0 * 9 / 16)
    assert cam.GetHorizontalApertureOffsetAttr().Get() == pytest.approx(3.6)
    assert tuple(cam.GetClippingRangeAttr().Get()) == pytest.approx((0.5, 200.0))
    settings = UsdRender.Settings(stage.GetPrimAtPath("/Render/Settings"))
    assert tuple(settings.GetResolutionAttr().Get()) == (960, 540)
    assert settings.GetCameraRel().GetTargets() == [cam.GetPath()]


def test_camera_portrait_auto_fit_and_orthographic(empty_scene):
    add_camera(type="ORTHO", ortho_scale=4.0, sensor_fit="AUTO")
    set_resolution(1080, 1920)
    stage, _ = export_current()
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/root/Cam"))
    assert cam.GetProjectionAttr().Get() == "orthographic"
    # Ortho scale spans the larger (vertical) side; tenths of a unit.
    assert cam.GetVerticalApertureAttr().Get() == pytest.approx(40.0)
    assert cam.GetHorizontalApertureAttr().Get() == pytest.approx(40.0 * 1080 / 1920)


def test_stage_metadata(empty_scene):
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30, 1.001
    scene.frame_start, scene.frame_end = 5, 42
    scene.unit_settings.scale_length = 0.01
    stage, _ = export_current()
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
    assert UsdGeom.GetStageMetersPerUnit(stage) == pytest.approx(0.01)
    assert stage.GetFramesPerSecond() == pytest.approx(30 / 1.001)
    assert stage.GetTimeCodesPerSecond() == pytest.approx(30 / 1.001)
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (5, 42)
    assert stage.GetDefaultPrim().GetPath() == "/root"


def test_a_view_layers_passes_become_a_render_product(empty_scene):
    """No passes: no product. Passes on: one RenderProduct named from Blender's output
    path, a RenderVar for Combined and one per pass (a Cryptomatte matte is one)."""
    add_camera()
    stage, _ = export_current()
    assert not UsdRender.Settings(stage.GetPrimAtPath("/Render/Settings")) \
        .GetProductsRel().GetTargets()
    layer = bpy.context.view_layer
    layer.use_pass_z = layer.use_pass_cryptomatte_object = True
    bpy.context.scene.render.filepath = "//renders/shot_###"
    stage, _ = export_current()
    settings = UsdRender.Settings(stage.GetPrimAtPath("/Render/Settings"))
    (product_path,) = settings.GetProductsRel().GetTargets()
    product = UsdRender.Product(stage.GetPrimAtPath(product_path))
    assert product.GetProductNameAttr().Get() == "renders/shot_$F3.exr"
    assert product.GetPrim().GetAttribute("lantern:viewLayer").Get() == layer.name
    sources = [UsdRender.Var(stage.GetPrimAtPath(p)).GetSourceNameAttr().Get()
               for p in product.GetOrderedVarsRel().GetTargets()]
    assert sources == ["color", "depth", "crypto_object"]


def test_product_names_follow_blenders_output_path():
    from lantern.exporters.gather.scene import product_name
    assert product_name("/tmp/") == "/tmp/$F4.exr"
    assert product_name("//out/beauty_####.exr") == "out/beauty_$F4.exr"
    assert product_name("/r/shot") == "/r/shot$F4.exr"
