"""Many lights: 20,000 small sphere lights over a plane render (their table fits GL's
texture size limit: engine/gpu/lights.py), add up exactly as they should, and with
shadows on stay within memory: lights past the shadow maps' budget are lit without
shadows, with one warning that names how many (engine/gpu/passes/shadows.py)."""
import json
import math
import subprocess
import sys

import numpy as np

LIGHTS, GROUPS = 20_000, 20
SIZE = 24


def many_lights_stage(positions, shadows):
    """A 100 m plane, a camera above it at an angle, and a sphere light (intensity 50,
    radius 0.05, treatAsPoint) at each position."""
    from pxr import Gf, Usd, UsdGeom

    from light_grids import add_sphere_lights
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    plane = UsdGeom.Mesh.Define(stage, "/root/plane")
    plane.CreateSubdivisionSchemeAttr("none")
    h = 50.0
    plane.CreatePointsAttr([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)])
    plane.CreateFaceVertexCountsAttr([4])
    plane.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    camera = UsdGeom.Camera.Define(stage, "/root/camera")
    camera.CreateFocalLengthAttr(18.0)
    look = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, -60, 60), Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 0, 1))
    camera.AddTransformOp().Set(look.GetInverse())
    add_sphere_lights(stage, "/root", positions, {"intensity": 50.0, "radius": 0.05}, shadows,
                      treat_as_point=True)
    return stage


def grid(count):
    """`count` positions 1 m above the plane, on a square grid over 90 m."""
    side = int(math.ceil(math.sqrt(count)))
    g = np.linspace(-45.0, 45.0, side)
    return [(float(g[i % side]), float(g[i // side]), 1.0) for i in range(count)]


def render(stage, light_error=0.01):
    from lantern.engine import RenderSettings, render_stage
    settings = RenderSettings(width=SIZE, height=SIZE, preset="low", ambient_occlusion=False,
                              fxaa=False, supersample=1, light_error=light_error,
                              lighting="clustered")
    return render_stage(stage, settings)


def test_20000_lights_equal_the_sum_of_20_renders_of_1000():
    positions = grid(LIGHTS)
    # A stage with lights gets no default light nor ambient term: its image is its
    # lights' sum alone.
    # Every light on its own (error 0): the sum is exact, as the volumes' blending is.
    whole = render(many_lights_stage(positions, False), 0.0).rgba[..., :3].astype(np.float64)
    step = LIGHTS // GROUPS
    parts = sum(render(many_lights_stage(positions[i:i + step], False), 0.0).rgba[..., :3]
                for i in range(0, LIGHTS, step))
    assert np.all(np.isfinite(whole)) and whole.mean() > 1.0, whole.mean()   # not black
    lit = parts > 1e-3 * parts.max()
    assert lit.mean() > 0.5                 # most of the image is lit
    error = np.abs(whole - parts)[lit] / parts[lit]
    assert error.max() <= 1e-4, error.max()


_SHADOWED = """
import json, sys
sys.path.insert(0, sys.argv[1])
from test_many_lights import LIGHTS, grid, many_lights_stage, render
import numpy as np
result = render(many_lights_stage(grid(LIGHTS), True))
# VmHWM is this address space's peak; getrusage's ru_maxrss is not: it survives
# execve, so it would report the parent test process's peak from before the fork.
with open("/proc/self/status") as status:
    peak_kib = next(int(line.split()[1]) for line in status if line.startswith("VmHWM:"))
print(json.dumps({"rss_mib": peak_kib / 1024,
                  "mean": float(result.rgba[..., :3].mean()),
                  "finite": bool(np.all(np.isfinite(result.rgba))),
                  "unshadowed": result.stats["unshadowed_lights"],
                  "shadow_maps": result.stats["shadow_maps"],
                  "warnings": result.warnings}))
"""


def test_20000_shadowed_lights_stay_in_memory_and_warn_once():
    """In its own process (usd-core, no bpy), to measure its peak resident memory."""
    import pathlib
    proc = subprocess.run([sys.executable, "-c", _SHADOWED, str(pathlib.Path(__file__).parent)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert got["rss_mib"] < 2048, got
    assert got["finite"] and got["mean"] > 1.0, got
    assert got["shadow_maps"] > 0 and got["unshadowed"] == LIGHTS - got["shadow_maps"], got
    from lantern.engine.gpu.passes.shadows import SHADOW_BUDGET_BYTES
    budget = [w for w in got["warnings"] if "lit without shadows" in w]
    assert budget == [f"{got['unshadowed']} of {LIGHTS} shadow-casting lights are lit without "
                      f"shadows: their shadow maps would pass the {SHADOW_BUDGET_BYTES >> 20} "
                      "MiB shadow memory budget"], got


def test_lights_past_the_budget_lose_their_shadows_and_the_warning_names_them(monkeypatch):
    """A budget of two low-preset cube maps and five shadow-casting lights: the two
    nearest the camera keep their maps, three are counted in one warning, which goes
    once no light casts."""
    from pxr import Sdf, UsdLux

    from lantern.engine import RenderSettings, Session
    from lantern.engine.gpu.passes import shadows
    monkeypatch.setattr(shadows, "SHADOW_BUDGET_BYTES", 2 * (3 * 512) * (2 * 512) * 4)
    # Along the view, the nearest first: importance is intensity over squared distance.
    positions = [(0.0, -40.0 + 10.0 * i, 1.0) for i in range(5)]
    stage = many_lights_stage(positions, True)
    settings = RenderSettings(width=SIZE, height=SIZE, preset="low", ambient_occlusion=False,
                              fxaa=False, supersample=1)
    with Session(stage, settings) as session:
        result = session.render()
        assert result.stats["shadow_maps"] == 2 and result.stats["unshadowed_lights"] == 3
        assert [w for w in result.warnings if "without shadows" in w] == [
            "3 of 5 shadow-casting lights are lit without shadows: their shadow maps would "
            "pass the 12 MiB shadow memory budget"], result.warnings
        assert set(session._renderer.shadows.maps) == {"/root/light_0", "/root/light_1"}
        with Sdf.ChangeBlock():
            for prim in stage.Traverse():
                if prim.IsA(UsdLux.SphereLight):
                    prim.GetAttribute("inputs:shadow:enable").Set(False)
        result = session.render()
        assert not [w for w in result.warnings if "without shadows" in w], result.warnings
