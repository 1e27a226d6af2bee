"""Implicit surfaces and curves: error against time (docs/status.md, "Implicit surfaces
and curves").

1. Implicit surfaces at 10 sides around (GeomUtil's default: what Storm draws and
   Blender's USD importer makes) to 96: HDR-FLIP of each implicit scene
   (tests/implicit_scenes.py, the high preset) against Cycles through the importer and
   against Cycles on the exact shape (the 128-sided mesh scenes), and the cost: a
   PointInstancer of 4,096 spheres at 640x360, medium, triangles drawn and the median
   of 5 warm frames, as a ratio to 10 sides in the same run.
2. Hair (tests/curve_scenes.build_hair): Lantern at the medium and high presets
   against Cycles at 4, 16 and 64 samples, each HDR-FLIP against the committed
   reference (Cycles at 512) and its time in the same run; then 1,000 to 40,000
   strands of 8 points: the stage read, the bytes uploaded, and the warm frame at
   640x360 medium.
Prints; asserts nothing.

    .venv/bin/python bench/bench_prims.py [implicit|hair]
"""
import pathlib
import sys
import tempfile
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import numpy as np  # noqa: E402

import curve_scenes  # noqa: E402
import implicit_scenes  # noqa: E402
from image_masks import over  # noqa: E402
from image_metrics import mean_flip  # noqa: E402
from lantern.engine import RenderSettings, Session, read_exr, render_file  # noqa: E402
from lantern.engine.usd import shapes  # noqa: E402

SIDES = (10, 24, 48, 96)
REFERENCES = TESTS / "references"


def _median_frame(stage, settings, frames=5):
    with Session(stage, settings) as session:
        first = session.render()
        times = []
        for _ in range(frames):
            t0 = time.perf_counter()
            session.render()
            times.append(time.perf_counter() - t0)
    return float(np.median(times)), first


def _spheres(n):
    from pxr import Gf, Usd, UsdGeom, UsdLux
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    pi = UsdGeom.PointInstancer.Define(stage, "/Balls")
    UsdGeom.Sphere.Define(stage, "/Balls/Protos/Ball").CreateRadiusAttr(0.4)
    pi.CreatePrototypesRel().SetTargets(["/Balls/Protos/Ball"])
    side = int(np.sqrt(n))
    pi.CreateProtoIndicesAttr([0] * n)
    pi.CreatePositionsAttr([Gf.Vec3f(i % side, i // side, 0.0) for i in range(n)])
    UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(3.0)
    return stage


def implicit():
    w, h = implicit_scenes.SIZE
    saved = shapes.SEGMENTS, shapes.LEVELS
    rows, base = [], None
    with tempfile.TemporaryDirectory() as tmp:
        for sides in SIDES:
            shapes.SEGMENTS, shapes.LEVELS = sides, (sides,)     # instanced ones too
            importer, exact = [], []
            for name in implicit_scenes.SCENES:
                path = implicit_scenes.write_stage(name, pathlib.Path(tmp) / f"{name}.usda")
                image = render_file(str(path), RenderSettings(width=w, height=h, preset="high",
                                                              transparent=True)).rgba
                ours = over(image, implicit_scenes.WORLD)
                for refs, suffix in ((importer, ""), (exact, "_mesh128")):
                    ref = read_exr(str(REFERENCES / "implicit" / f"{name}{suffix}.exr"))
                    refs.append(mean_flip(ours, over(ref, implicit_scenes.WORLD)))
            seconds, result = _median_frame(_spheres(4096), RenderSettings(
                width=640, height=360, preset="medium"))
            triangles = 4096 * (sides * sides - 2 * sides)
            base = base or seconds
            rows.append(f"| {sides} | {np.mean(importer):.4f} ({np.max(importer):.4f}) | "
                        f"{np.mean(exact):.4f} ({np.max(exact):.4f}) | {triangles / 1e6:.1f} M | "
                        f"{seconds * 1e3:.0f} | {seconds / base:.2f} |")
            print(rows[-1], flush=True)
    shapes.SEGMENTS, shapes.LEVELS = saved
    sides = shapes.segments_for(4096)
    seconds, _ = _median_frame(_spheres(4096), RenderSettings(width=640, height=360,
                                                              preset="medium"))
    rows.append(f"| 48 alone, {sides} instanced (the default) | as 48 | as 48 | "
                f"{4096 * (sides * sides - 2 * sides) / 1e6:.1f} M | {seconds * 1e3:.0f} | "
                f"{seconds / base:.2f} |")
    print("| sides | FLIP vs importer, mean (worst) | FLIP vs exact shape | 4,096 spheres: "
          "triangles | frame ms | x 10 sides |")
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))


def _cycles(samples, w, h):
    import bpy
    sys.path.insert(0, str(REFERENCES))
    from make_cycles_references import configure_cycles
    scene = curve_scenes.build_hair()
    configure_cycles(scene, samples, point_filter=False)
    with tempfile.TemporaryDirectory() as tmp:
        scene.render.image_settings.file_format = 'OPEN_EXR'
        scene.render.filepath = str(pathlib.Path(tmp) / "c.exr")
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - t0
        return read_exr(str(pathlib.Path(tmp) / "c.exr"))[..., :3], seconds


def hair():
    import bpy
    from lantern.exporters import stage_from_depsgraph
    w, h = curve_scenes.HAIR_SIZE
    ref = read_exr(str(REFERENCES / "curves" / "hair.exr"))
    curve_scenes.build_hair()
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    for preset in ("medium", "high"):
        seconds, result = _median_frame(stage, RenderSettings(width=w, height=h, preset=preset))
        print(f"Lantern {preset}: {seconds * 1e3:.0f} ms warm, FLIP {mean_flip(result.rgba, ref):.4f}")
    for samples in (4, 16, 64):
        image, seconds = _cycles(samples, w, h)
        print(f"Cycles {samples} spp: {seconds * 1e3:.0f} ms, FLIP {mean_flip(image, ref):.4f}")
    from pxr import Gf, Usd, UsdGeom, UsdLux
    for n in (1000, 10000, 40000):
        stage = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
        rng = np.random.default_rng(1)
        roots = rng.uniform(-1, 1, (n, 2))
        t = np.linspace(0, 1, 8)
        pts = np.stack([roots[:, :1] + 0.1 * np.sin(6 * t)[None], roots[:, 1:] + 0.2 * t[None] ** 2,
                        np.broadcast_to(0.8 * t[None], (n, 8))], -1).reshape(-1, 3)
        c = UsdGeom.BasisCurves.Define(stage, "/Hair")
        c.CreateTypeAttr("cubic")
        c.CreateBasisAttr("catmullRom")
        c.CreateWrapAttr("pinned")
        c.CreateCurveVertexCountsAttr([8] * n)
        c.CreatePointsAttr([Gf.Vec3f(*p) for p in pts])
        c.CreateWidthsAttr([0.004])
        UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(3.0)
        with Session(stage, RenderSettings(width=640, height=360, preset="medium")) as session:
            first = session.render()
            frames = []
            for _ in range(3):
                t0 = time.perf_counter()
                session.render()
                frames.append(time.perf_counter() - t0)
        print(f"{n} strands: read {first.timings['load'] * 1e3:.0f} ms, "
              f"{first.stats['points_drawn']} pieces, {first.stats['bytes_uploaded'] / 2**20:.1f} MiB "
              f"uploaded, warm frame {np.median(frames) * 1e3:.0f} ms", flush=True)


if __name__ == "__main__":
    parts = sys.argv[1:] or ["implicit", "hair"]
    if "implicit" in parts:
        implicit()
    if "hair" in parts:
        hair()
