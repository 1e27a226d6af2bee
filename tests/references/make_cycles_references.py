"""Renders the reference scenes with Cycles once; the small EXRs are committed.

Every set: CPU, a fixed seed (0), no denoiser, no adaptive sampling, direct light only
(max bounces 0: each surface is lit once by the lights and by the world), light tree
threshold 0.
- calibration: one light over a white plane (calibration.build_scene), 4096 spp,
  near-point pixel filter (0.01 px), cycles_<light>.exr;
- box: a box on the plane, shadows on (calibration.build_box_scene), 2048 spp,
  near-point pixel filter, cycles_box_<light>.exr. Lantern had no anti-aliasing then,
  so these measure light, not edges;
- penumbra (area-light shadows, docs/rendering.md): penumbra_scenes.SCENES (a box under a
  rect and under a disk light, the demo lit by its area light only), 2048 spp,
  near-point pixel filter, penumbra/<scene>.exr;
- highlight (area-light highlights, docs/rendering.md): highlight_scenes.SCENES (a glossy
  floor reflecting a rect or a disk light, a gold sphere), highlight_scenes.SAMPLES spp,
  Cycles' default pixel filter, highlight/<scene>.exr (RGB, half float);
- clearcoat: a sphere in a white furnace, coat weight x coat roughness x dark and
  bright base (clearcoat_scenes.CASES), clearcoat_scenes.SAMPLES spp, Cycles' default
  pixel filter, clearcoat/<case>.exr (RGB, float32);
- looks (the shading work, docs/rendering.md): the scenes of reference_scenes.SCENES,
  each at its own size and samples, with Cycles' default pixel filter (Blackman-Harris, 1.5 px): the images a
  user compares against, anti-aliased edges included. 8 transparent bounces (blended
  planes and cut-outs are crossed by camera and shadow rays). Written as
  looks/<scene>.exr: RGB, half float (float32 for tex_gradient16, whose levels are
  the point), ZIP.

`before` renders each looks scene with the Lantern importable in this process (the
medium preset, the same size) and writes looks/BEFORE.md (or --out): mean HDR-FLIP and
PSNR against the reference, and the render time. The committed BEFORE.md was made with
main as it was before the shading work (commit a55bdc4) first on the import path:
    git archive a55bdc4 | tar -x -C /tmp/base/lantern
    PYTHONPATH=/tmp/base .venv/bin/python tests/references/make_cycles_references.py before \
        --label "Lantern at a55bdc4 (main before the shading work)"
and EXPORTER.md with this branch (the exporter half of the shading work, the engine unchanged).

Run from the repository root (no argument: all sets):
    .venv/bin/python tests/references/make_cycles_references.py [calibration|box|penumbra|clearcoat|highlight|looks] [NAME ...]
    .venv/bin/python tests/references/make_cycles_references.py before [--label TEXT] [--out FILE.md] [NAME ...]
"""
import pathlib
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402

import calibration  # noqa: E402
import clearcoat_scenes  # noqa: E402
import highlight_scenes  # noqa: E402
import penumbra_scenes  # noqa: E402
import reference_scenes  # noqa: E402

LOOKS = HERE / "looks"
WORKDIR = pathlib.Path(tempfile.gettempdir()) / "lantern-reference-textures"

SETS = {
    "calibration": (calibration.build_scene, calibration.LIGHTS, "cycles_{}.exr", 4096),
    "box": (calibration.build_box_scene, calibration.BOX_LIGHTS, "cycles_box_{}.exr", 2048),
    "penumbra": (penumbra_scenes.build, penumbra_scenes.SCENES, "penumbra/{}.exr", 2048),
}


def configure_cycles(scene, samples, point_filter):
    scene.render.engine = 'CYCLES'
    cycles = scene.cycles
    cycles.device = 'CPU'
    cycles.samples = samples
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = 0
    cycles.max_bounces = 0
    cycles.transparent_max_bounces = 8
    cycles.light_sampling_threshold = 0.0
    cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    if point_filter:
        cycles.filter_width = 0.01
    else:
        cycles.pixel_filter_type, cycles.filter_width = 'BLACKMAN_HARRIS', 1.5
    scene.render.film_transparent = False
    scene.view_settings.exposure = 0.0


def write_exr(scene, path, half=False, rgb=False):
    settings = scene.render.image_settings
    settings.file_format = 'OPEN_EXR'
    settings.color_depth = '16' if half else '32'
    settings.color_mode = 'RGB' if rgb else 'RGBA'
    settings.exr_codec = 'ZIP'
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def render(build, kind, filename, samples):
    scene = build(kind)
    configure_cycles(scene, samples, point_filter=True)
    (HERE / filename.format(kind)).parent.mkdir(exist_ok=True)
    write_exr(scene, HERE / filename.format(kind))


def render_look(name):
    spec = reference_scenes.SCENES[name]
    scene = reference_scenes.build(name, WORKDIR)
    configure_cycles(scene, spec.samples, point_filter=False)
    LOOKS.mkdir(exist_ok=True)
    start = time.perf_counter()
    write_exr(scene, LOOKS / f"{name}.exr", half=(name != "tex_gradient16"), rgb=True)
    print(f"{name}: {spec.size[0]}x{spec.size[1]}, {spec.samples} spp, "
          f"{time.perf_counter() - start:.1f} s")


def render_clearcoat(name):
    scene = clearcoat_scenes.build(name)
    configure_cycles(scene, clearcoat_scenes.SAMPLES, point_filter=False)
    (HERE / "clearcoat").mkdir(exist_ok=True)
    start = time.perf_counter()
    write_exr(scene, HERE / "clearcoat" / f"{name}.exr", rgb=True)
    print(f"{name}: {time.perf_counter() - start:.1f} s", flush=True)


def render_highlight(name):
    scene = highlight_scenes.build(name)
    configure_cycles(scene, highlight_scenes.SAMPLES, point_filter=False)
    (HERE / "highlight").mkdir(exist_ok=True)
    start = time.perf_counter()
    write_exr(scene, HERE / "highlight" / f"{name}.exr", half=True, rgb=True)
    print(f"{name}: {time.perf_counter() - start:.1f} s", flush=True)


def lantern_against_reference(name):
    """(mean HDR-FLIP, PSNR dB, render seconds) of this process's Lantern on `name`."""
    from image_metrics import mean_flip, psnr
    from lantern.engine import RenderSettings, read_exr, render_stage
    from lantern.exporters import stage_from_depsgraph
    spec = reference_scenes.SCENES[name]
    reference_scenes.build(name, WORKDIR)
    # As `lantern render scene.blend` does: an in-memory stage, default options.
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    width, height = spec.size
    settings = RenderSettings(width=width, height=height, preset="medium")
    render_stage(stage, settings)                          # warm: shaders, textures
    start = time.perf_counter()
    result = render_stage(stage, settings)
    seconds = time.perf_counter() - start
    reference = read_exr(str(LOOKS / f"{name}.exr"))
    return mean_flip(result.rgba, reference), psnr(result.rgba, reference), seconds


def before(names, label, out="BEFORE.md"):
    rows = []
    for name in names:
        flip, db, seconds = lantern_against_reference(name)
        rows.append(f"| {name} | {flip:.4f} | {db:.2f} | {seconds * 1000:.0f} |")
        print(rows[-1], flush=True)
    import datetime
    import platform
    text = [
        "# Lantern against the Cycles references",
        "",
        f"{label}. Measured {datetime.date.today()} on {platform.machine()}, "
        f"{platform.processor() or 'CPU'}, Mesa llvmpipe (no GPU), with "
        "`make_cycles_references.py before`: the medium preset at the reference's size, "
        "mean HDR-FLIP (flip-evaluator) and PSNR (tests/image_metrics.py), and the time of "
        "a second, warm render (the first compiles shaders and loads textures).",
        "",
        "| scene | FLIP | PSNR dB | render ms |",
        "|---|---|---|---|",
        *rows,
        "",
    ]
    (LOOKS / out).write_text("\n".join(text))


if __name__ == "__main__":
    args = sys.argv[1:]
    chosen = [args.pop(0)] if args else list(SETS) + ["clearcoat", "highlight", "looks"]
    if chosen == ["before"]:
        options = {"--label": "Lantern on this import path", "--out": "BEFORE.md"}
        while args[:1] and args[0] in options:
            options[args[0]] = args[1]
            args = args[2:]
        before(args or list(reference_scenes.SCENES), options["--label"], options["--out"])
        raise SystemExit(0)
    for name in chosen:
        if name == "clearcoat":
            for case in args or clearcoat_scenes.CASES:
                render_clearcoat(case)
            continue
        if name == "highlight":
            for case in args or highlight_scenes.SCENES:
                render_highlight(case)
            continue
        if name == "looks":
            for look in args or reference_scenes.SCENES:
                render_look(look)
            continue
        build, lights, filename, samples = SETS[name]
        for kind in args or lights:
            render(build, kind, filename, samples)
