"""Light volumes at work: 1 light against 256 small point lights at 640x360.

Fragments outside a light's volume are not shaded, so many small lights should cost
about what one light covering the view costs (target: 256 lights <= 2x). "Small":
0.002 W each, whose volume (engine/lighting.py: where a white Lambert surface would
reflect less than 1e-4 W/(sr m2)) reaches about 0.7 m. Shadows off: shadowless point
lights share one instanced draw. Reported twice: the render (G-buffer, lights,
resolve) and the total with reading the stage, which costs Python time per light prim.
Prints figures, asserts nothing. Runs without Blender (usd-core).
"""
import math
import time

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from lantern.engine import RenderSettings, render_stage

WIDTH, HEIGHT = 640, 360


def stage_with_lights(lights):
    """A 24 m white plane seen from above at an angle, and (position, power) lights."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    material = UsdShade.Material.Define(stage, "/root/white")
    shader = UsdShade.Shader.Define(stage, "/root/white/surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((0.8, 0.8, 0.8))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    plane = UsdGeom.Mesh.Define(stage, "/root/plane")
    h = 12.0
    plane.CreatePointsAttr([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)])
    plane.CreateFaceVertexCountsAttr([4])
    plane.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdShade.MaterialBindingAPI.Apply(plane.GetPrim()).Bind(material)
    camera = UsdGeom.Camera.Define(stage, "/root/camera")
    camera.CreateFocalLengthAttr(24.0)
    camera.CreateHorizontalApertureAttr(36.0)
    camera.CreateVerticalApertureAttr(36.0 * HEIGHT / WIDTH)
    look = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, -14, 10), Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 0, 1))
    camera.AddTransformOp().Set(look.GetInverse())
    for i, (position, power) in enumerate(lights):
        light = UsdLux.SphereLight.Define(stage, f"/root/light_{i:03d}")
        light.CreateIntensityAttr(power / math.pi)
        light.CreateRadiusAttr(0.02)
        light.CreateNormalizeAttr(True)
        UsdLux.ShadowAPI.Apply(light.GetPrim()).CreateShadowEnableAttr(False)
        light.AddTranslateOp().Set(Gf.Vec3d(*position))
    return stage


def frame_time(stage, runs=5):
    """Median (total, render without the stage read) seconds, and the last result."""
    settings = RenderSettings(width=WIDTH, height=HEIGHT)
    render_stage(stage, settings)  # warm: context, shaders
    totals, renders, result = [], [], None
    for _ in range(runs):
        start = time.perf_counter()
        result = render_stage(stage, settings)
        totals.append(time.perf_counter() - start)
        renders.append(totals[-1] - result.timings["load"])
    return float(np.median(totals)), float(np.median(renders)), result


def main():
    one = stage_with_lights([((0.0, 0.0, 3.0), 2000.0)])
    grid = np.linspace(-10.0, 10.0, 16)
    many = stage_with_lights([((x, y, 0.3), 0.002) for x in grid for y in grid])
    t1, render1, r1 = frame_time(one)
    t256, render256, r256 = frame_time(many)
    print(f"light scaling at {WIDTH}x{HEIGHT} ({time.strftime('%Y-%m-%d')}, llvmpipe):")
    for name, total, render, result in (("1 light", t1, render1, r1), ("256 lights", t256, render256, r256)):
        print(f"  {name:<11} render {render * 1000:7.1f} ms (light pass "
              f"{result.gpu_timings['lights'] * 1000:.1f} ms on the GPU, {result.stats['light_volumes']} volumes), "
              f"total with stage read {total * 1000:.1f} ms")
    print(f"  ratio 256/1: render {render256 / render1:.2f}x (target <= 2x), "
          f"total {t256 / t1:.2f}x")


if __name__ == "__main__":
    main()
