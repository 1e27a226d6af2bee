"""Many lights: 1 to 16,384 small point lights over a plane at 640x360, each count in
its own process, reporting render time and peak resident memory against one light, in
both forms of the light pass: clustered (the light tree within its 1% bound: far
lights in groups, none cut) and the light volumes (each light cut where it reflects
1% of what the scene's brightest light reflects at 1 m: engine/lighting.py).

Small lights (0.002 W each, radius 0.02 m) on a grid over a 24 m white plane, 0.3 m
above it: every pixel of the plane lies under the grid, among many lights within a
metre, the hardest case for groups (tests/test_light_tree.py and bench_gpu.py --lights
measure a patch, with the error against numpy's sum). With shadows on, every light casts onto the plane: maps past the
shadow memory budget (engine/gpu/passes/shadows.py) are not made, those lights are lit
without shadows, and memory stays bounded. The stage is authored as Sdf specs (fast)
and read by the engine like any other; "load" is the engine's stage read, "render"
the rest (G-buffer, shadows, lights, resolve, read-back), both medians of 3 warm runs.
Prints figures, asserts nothing. Runs without Blender (usd-core).
"""
import json
import math
import pathlib
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))

WIDTH, HEIGHT = 640, 360
COUNTS = (1, 16, 256, 1024, 4096, 16384)
SHADOWED = (1, 256, 16384)


def peak_rss_mib() -> float:
    """This process's peak resident memory. Not getrusage's ru_maxrss: that survives
    execve, so a child would report its parent's peak from before the fork."""
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024


def stage_with_lights(positions, power, shadows):
    """A 24 m white plane seen from above at an angle, and a sphere light of `power`
    watts at each position."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

    from light_grids import add_sphere_lights
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    material = UsdShade.Material.Define(stage, "/root/white")
    shader = UsdShade.Shader.Define(stage, "/root/white/surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((0.8, 0.8, 0.8))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    plane = UsdGeom.Mesh.Define(stage, "/root/plane")
    plane.CreateSubdivisionSchemeAttr("none")
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
    add_sphere_lights(stage, "/root", positions,
                      {"intensity": power / math.pi, "radius": 0.02, "normalize": True}, shadows)
    return stage


def lights(count):
    """One bright light high up, or `count` small ones on a grid 0.3 m over the plane."""
    if count == 1:
        return [(0.0, 0.0, 3.0)], 2000.0
    side = int(math.ceil(math.sqrt(count)))
    g = np.linspace(-10.0, 10.0, side)
    return [(float(g[i % side]), float(g[i // side]), 0.3) for i in range(count)], 0.002


FORMS = {"clustered": {}, "volumes": {"lighting": "volumes", "compute": False}}


def measure(count, shadows, form="clustered", runs=3):
    """This process: one count's figures, as JSON on stdout."""
    from lantern.engine import RenderSettings, render_stage
    positions, power = lights(count)
    stage = stage_with_lights(positions, power, shadows)
    settings = RenderSettings(width=WIDTH, height=HEIGHT, **FORMS[form])
    result = render_stage(stage, settings)  # warm: context, shaders
    loads, renders = [], []
    for _ in range(runs):
        start = time.perf_counter()
        result = render_stage(stage, settings)
        total = time.perf_counter() - start
        loads.append(result.timings["load"])
        renders.append(total - result.timings["load"])
    print(json.dumps({
        "load_ms": 1000 * float(np.median(loads)), "render_ms": 1000 * float(np.median(renders)),
        "light_pass_ms": 1000 * (result.gpu_timings.get("lights", 0.0)
                                 + result.gpu_timings.get("light_cull", 0.0)),
        "rss_mib": peak_rss_mib(),
        "shadow_maps": result.stats.get("shadow_maps", 0),
        "unshadowed": result.stats.get("unshadowed_lights", 0),
        "finite": bool(np.all(np.isfinite(result.rgba))),
        "mean": float(result.rgba[..., :3].mean())}))


def run(count, shadows, form):
    proc = subprocess.run([sys.executable, __file__, "--one", str(count), str(int(shadows)), form],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        return {"error": (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main():
    print(f"light scaling at {WIDTH}x{HEIGHT} ({time.strftime('%Y-%m-%d')}, llvmpipe), "
          "each count in its own process; ratios against 1 light of the same kind and form:")
    print(f"  {'form':>9} {'lights':>6} {'shadows':>7} {'load ms':>9} {'render ms':>10} "
          f"{'x1':>6} {'light pass ms':>13} {'peak RSS MiB':>12} {'x1':>5} {'maps':>5} "
          f"{'unshadowed':>10}")
    for form in FORMS:
        for shadows in (False, True):
            one = None
            for count in COUNTS if not shadows else SHADOWED:
                got = run(count, shadows, form)
                label = f"  {form:>9} {count:>6} {'on' if shadows else 'off':>7}"
                if "error" in got:
                    print(f"{label} failed: {got['error']}")
                    continue
                one = one or got
                print(f"{label} {got['load_ms']:9.1f} {got['render_ms']:10.1f} "
                      f"{got['render_ms'] / one['render_ms']:6.2f} "
                      f"{got['light_pass_ms']:13.1f} {got['rss_mib']:12.0f} "
                      f"{got['rss_mib'] / one['rss_mib']:5.2f} {got['shadow_maps']:>5} "
                      f"{got['unshadowed']:>10}" + ("" if got["finite"] else "  NON-FINITE"))


if __name__ == "__main__":
    if sys.argv[1:2] == ["--one"]:
        measure(int(sys.argv[2]), sys.argv[3] == "1", *sys.argv[4:5])
    else:
        main()
