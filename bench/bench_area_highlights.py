"""Area-light highlights: the highlight scenes (tests/highlight_scenes.py: a glossy floor
reflecting a rect or a disk light, a gold sphere) at every preset against their
committed Cycles references (tests/references/highlight/, 1024 spp, bounces 0): mean
HDR-FLIP and warm render time (median of 3), and Cycles at 1, 4 and 16 samples in the
same run for scale (`--no-cycles`: Lantern only; `--out DIR`: Lantern's medium images as
EXR; scene names: those only). Asserts nothing."""
import pathlib
import sys
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402

import highlight_scenes  # noqa: E402
from bench_cycles_shadows import warm_render  # noqa: E402
from image_metrics import mean_flip  # noqa: E402
from lantern.core.presets import PRESETS  # noqa: E402
from lantern.engine import RenderSettings, read_exr  # noqa: E402
from lantern.engine.bounces import DIRECT  # noqa: E402
from lantern.exporters import stage_from_depsgraph  # noqa: E402


def cycles_at(name, samples, path):
    """(image, seconds) of Cycles at `samples` spp, configured as the references."""
    sys.path.insert(0, str(TESTS / "references"))
    from make_cycles_references import configure_cycles
    scene = highlight_scenes.build(name)
    configure_cycles(scene, samples, point_filter=False)
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.filepath = str(path)
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return read_exr(str(path)), time.perf_counter() - start


def main():
    args = sys.argv[1:]
    with_cycles = "--no-cycles" not in args
    out = pathlib.Path(args[args.index("--out") + 1]) if "--out" in args else None
    names = [a for a in args if a in highlight_scenes.SCENES] or list(highlight_scenes.SCENES)
    width, height = highlight_scenes.SIZE
    print(f"area-light highlights at {width}x{height} vs Cycles {highlight_scenes.SAMPLES} spp "
          f"({time.strftime('%Y-%m-%d')}, llvmpipe); FLIP (warm ms)")
    for name in names:
        reference = read_exr(str(TESTS / "references" / "highlight" / f"{name}.exr"))
        highlight_scenes.build(name)
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        row = f"{name:<11}"
        for preset in PRESETS:
            settings = RenderSettings(width=width, height=height, preset=preset,
                                      bounces=DIRECT)           # the references
            result, ms = warm_render(stage, settings)
            row += f"  {preset} {mean_flip(result.rgba, reference):.4f} ({ms:.0f})"
            if out is not None and preset == "medium":
                from lantern.engine.image_io import write_image
                out.mkdir(parents=True, exist_ok=True)
                write_image(str(out / f"{name}.exr"), result.rgba)
                write_image(str(out / f"{name}.png"), result.rgba)
        if with_cycles:
            for samples in (1, 4, 16):
                image, seconds = cycles_at(name, samples, f"/tmp/lantern-highlight-{samples}.exr")
                row += f"  cycles {samples} {mean_flip(image, reference):.4f} ({seconds * 1000:.0f})"
        print(row, flush=True)


if __name__ == "__main__":
    main()
