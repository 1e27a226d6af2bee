"""An ellipse light (a UsdLux DiskLight stretched by its xform: docs/stage_contract.md)
lights a white Lambert plane as an emissive polygon of the same shape and radiance does
(the stretched equal-area 32-gon the medium preset shades it as), within 1%, through
both forms of the light pass: its semi-axes, area and radiance are read from the
transform, and its polygon is packed and shaded as the ellipse's."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

from emitter_scenes import CENTRE, FORMS, INTENSITY, SIZE, H, W, plane_mask, stage_with
from lantern.core.presets import preset
from lantern.engine import RenderSettings, render_stage

SEMI = (SIZE[0] / 2, SIZE[1] / 2)          # the ellipse's semi-axes, along x and y
RADIANCE = INTENSITY / (math.pi * SEMI[0] * SEMI[1])


def ellipse_stage():
    stage = stage_with("rect")
    stage.RemovePrim("/root/rect")
    disk = UsdLux.DiskLight.Define(stage, "/root/ellipse")
    disk.CreateIntensityAttr(INTENSITY)
    disk.CreateNormalizeAttr(True)
    disk.CreateRadiusAttr(SEMI[0])
    disk.AddTranslateOp().Set(Gf.Vec3d(*CENTRE))
    disk.AddScaleOp(UsdGeom.XformOp.PrecisionDouble, "ellipse").Set(
        Gf.Vec3d(1.0, SEMI[1] / SEMI[0], 1.0))
    return stage


def polygon_stage():
    """The ellipse's equal-area 32-gon as one emissive face, facing down."""
    stage = stage_with("rect")
    stage.RemovePrim("/root/rect")
    mat = UsdShade.Material.Define(stage, "/root/glow")
    surface = UsdShade.Shader.Define(stage, "/root/glow/surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(
        Gf.Vec3f(RADIANCE, RADIANCE, RADIANCE))
    mat.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    sides = preset("medium").disk_sides
    grow = math.sqrt(2 * math.pi / (sides * math.sin(2 * math.pi / sides)))
    ang = np.arange(sides) * 2 * math.pi / sides
    mesh = UsdGeom.Mesh.Define(stage, "/root/panel")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([(SEMI[0] * grow * math.cos(a), SEMI[1] * grow * math.sin(a), 0.0)
                           for a in ang])
    mesh.CreateFaceVertexCountsAttr([sides])
    mesh.CreateFaceVertexIndicesAttr(list(range(sides))[::-1])     # its normal along -z
    mesh.AddTranslateOp().Set(Gf.Vec3d(*CENTRE))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    return stage


def render(stage, form):
    res = render_stage(stage, RenderSettings(width=W, height=H, preset="medium", **FORMS[form]))
    assert np.isfinite(res.rgba).all() and res.warnings == [], res.warnings
    return res.rgba[..., 0]


@pytest.mark.parametrize("form", sorted(FORMS))
def test_an_ellipse_light_lights_as_its_polygon_of_the_same_radiance(form):
    ellipse, polygon = render(ellipse_stage(), form), render(polygon_stage(), form)
    mask = plane_mask() & (polygon > 0.02 * polygon.max())
    assert mask.sum() > 200
    err = float(np.max(np.abs(ellipse[mask] - polygon[mask]) / polygon[mask]))
    print(f"{form}: worst relative difference {err:.2e}")
    assert err < 0.01
