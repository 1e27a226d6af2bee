"""What the dome's reflections and their occlusion cost (docs/rendering.md, "Environment
light" and "Ambient occlusion"): a scene rendered at 1920 x 1080 (medium unless
--preset), the median of --frames warm frames of one Session: the wall time of a frame
and the GPU time of the AO pass (the occlusion search, the specular slice and the
blur) and the ambient pass (the dome's light), from the engine's timestamp queries.

The scene: a .blend (exported in memory, as `lantern render scene.blend` does), by
default the comparison suite's mirror ball on a plane under the sky
(05_metallic_sphere_light, its broken links repaired as the suite repairs them). Run
the same command on two checkouts to compare them; no Cycles, asserts nothing.

    .venv/bin/python bench/bench_dome.py [--blend FILE] [--frames 9] [--preset medium]
"""
import argparse
import pathlib
import statistics
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
CORPUS = HERE.parent.parent / "shared" / "corpus" / "blender"
SIZE = (1920, 1080)
PASSES = ("ao", "ambient")


def repaired(name, folder):
    """The corpus scene `name`, copied with its links repaired (bench/compare_suite.py)."""
    sys.path.insert(0, str(HERE.parent / "tests"))
    sys.path.insert(0, str(HERE))
    import compare_suite
    target = pathlib.Path(folder) / f"{name}.blend"
    compare_suite.repair_copy(CORPUS / f"{name}.blend", target, folder)
    return target


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blend", default=None)
    parser.add_argument("--frames", type=int, default=9)
    parser.add_argument("--preset", default="medium")
    args = parser.parse_args()
    import lantern.exporters as exporters  # Blender's pxr first
    import bpy
    from lantern.engine import RenderSettings, Session
    with tempfile.TemporaryDirectory(prefix="lantern-bench-dome-") as folder:
        blend = args.blend or repaired("05_metallic_sphere_light", folder)
        bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
        stage, _ = exporters.stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    settings = RenderSettings(width=SIZE[0], height=SIZE[1], preset=args.preset,
                              frame=float(bpy.context.scene.frame_current))
    with Session(stage, settings) as session:
        session.render()                                   # programs, uploads, cubes
        wall, gpu = [], {name: [] for name in PASSES}
        for _ in range(args.frames):
            start = time.perf_counter()
            result = session.render()
            wall.append(time.perf_counter() - start)
            for name in PASSES:
                gpu[name].append(result.gpu_timings.get(name, 0.0))
    print(f"{pathlib.Path(str(blend)).name} at {SIZE[0]}x{SIZE[1]}, {args.preset}, median of "
          f"{args.frames}: frame {1000 * statistics.median(wall):.1f} ms; GPU " +
          ", ".join(f"{name} {1000 * statistics.median(t):.1f} ms" for name, t in gpu.items()))


if __name__ == "__main__":
    sys.exit(main())
