"""Frame time on the machine at hand, with the CPU and GPU time of every pass and the
read-back: the demo scene, the 16-character crowd's frame change and a view change on
1,000 cubes, at 640x360, 1920x1080 and 3840x2160, presets low to ultra; and the demo
with its subdivision exported as a cage (tessellated on the GPU from GL 4.3). Each
in the frame's forms (--forms): `compute` (clustered lighting and the screen passes in
compute, the default where GL 4.3 runs), `volumes` (light volumes, the rest compute) and
`raster` (every pass in its raster form, as GL 3.3 and 4.1 draw).

Many lights (--lights): 1, 256 and 16,384 small point lights in a 2 m patch 1 m over a
plane seen from above (tests/test_light_tree.py's scene), 1920x1080, medium, each
with its error against the exact sum of all lights (numpy, on a grid of pixels).

    python bench/bench_gpu.py prepare DIR      # here, with bpy: the scenes as USD files
    python bench/bench_gpu.py run DIR [--json F] [--images DIR] [--sizes ...] [--presets ...]
    python bench/bench_gpu.py                  # both (make bench): out/gpu_scenes, low and
                                               # medium at 640x360 and 1920x1080

`run` needs no bpy, so it runs on the GPU machine (../shared/gpu/README.md) as well
as on llvmpipe. A frame is `Session.render` until the image is in host memory, warm
(the scene read, programs compiled and meshes uploaded before). The readback is timed
three ways: float32 blocking (F12), half floats blocking (a viewport), and queued
behind a fence in a sequence (Session.render_frames), whose figure is the frame
interval. The frame is printed both ways: into a caller's buffer, reused (the engine
host's shared memory), and into a new array (Session.render() without out=); the read
mode (engine/gpu/readback.py) is LANTERN_READBACK's. `--images` saves each scene's
medium image at 640x360 (`--image-sizes`) as a compressed .npz, to compare one
machine's pixels with another's (`compare DIR_A DIR_B`)."""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import statistics
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
SCENES = ("demo", "crowd", "cubes", "demo_cage")
# The frame's forms (RenderSettings): every pass that can in compute, the light volumes
# with the rest in compute, every pass in its raster form, and Lantern's own choice
# (a GPU: compute; a software rasteriser: clustered lights, the rest raster).
FORMS = {"compute": {"compute": True}, "volumes": {"compute": True, "lighting": "volumes"},
         "raster": {"compute": False, "lighting": "volumes"}, "default": {}}
LIGHT_COUNTS = (1, 256, 16384)
LIGHTS_SIZE = (1920, 1080)
LIGHTS_EXTENT = 48.0            # metres across the many-lights image
SIZES = {"640x360": (640, 360), "1920x1080": (1920, 1080), "3840x2160": (3840, 2160)}
PRESETS = ("low", "medium", "high", "ultra")
RUNS = 3
# Targets above this many drawn pixels (size x supersampling squared: 1080p) are skipped
# unless --all: llvmpipe on 2 cores takes minutes and gigabytes for them.
LLVMPIPE_PIXELS = 2_100_000


# --- prepare (bpy) ---------------------------------------------------------------------
def prepare(folder: pathlib.Path):
    sys.path[:0] = [str(HERE), str(HERE.parent / "tests")]
    import lantern.exporters  # noqa: F401  (Blender's pxr first)
    import bpy
    from lantern.exporters import stage_from_depsgraph
    from lantern.exporters.api import ExportOptions, export_depsgraph_to_file
    from bench_session import crowd_scene
    import session_scenes
    folder.mkdir(parents=True, exist_ok=True)
    demo = HERE.parent / "out" / "demo.usdc"
    if not demo.is_file():
        raise SystemExit(f"{demo}: missing; run `make demo` first")
    shutil.copy2(demo, folder / "demo.usdc")          # with its textures, by relative path
    shutil.copytree(demo.parent / "demo_textures", folder / "demo_textures", dirs_exist_ok=True)
    bpy.ops.wm.open_mainfile(filepath=str(demo.with_suffix(".blend")))
    cage = demo.parent / "demo_cage.usdc"     # beside demo_textures, which it names relatively
    export_depsgraph_to_file(bpy.context.evaluated_depsgraph_get(), str(cage),
                             ExportOptions(subdivision="cage", animation=False))
    shutil.copy2(cage, folder / cage.name)
    crowd_scene()
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    stage.Export(str(folder / "crowd.usdc"))
    session_scenes.cubes_stage(1000, lights=("point", "spot")).Export(str(folder / "cubes.usdc"))
    for count in LIGHT_COUNTS:
        lights_stage(count).Export(str(folder / f"lights_{count}.usdc"))
    print(f"wrote {', '.join(f'{n}.usdc' for n in SCENES)} and the many-lights scenes into "
          f"{folder}")


def light_positions(count):
    """`count` lights on a square grid over the 2 m patch (one: its centre)."""
    side = int(round(count ** 0.5))
    g = (np.arange(side) + 0.5) / side * 2.0 - 1.0
    return [(float(x), float(y), 1.0) for y in g for x in g]


def lights_stage(count):
    """The plane and `count` lights of 32.768 W in all (tests/test_light_tree.py)."""
    sys.path.insert(0, str(HERE.parent / "tests"))
    from test_light_tree import plane_stage
    from pxr import UsdGeom
    stage = plane_stage(light_positions(count), 32.768 / count, extent=LIGHTS_EXTENT)
    camera = UsdGeom.Camera.Get(stage, "/root/camera")
    w, h = LIGHTS_SIZE
    camera.GetVerticalApertureAttr().Set(LIGHTS_EXTENT * 10 * h / w)
    return stage


# --- run (no bpy) ----------------------------------------------------------------------
def _changes(name, stage):
    """(frame, view) per run: what changes between frames in this scene."""
    if name == "crowd":
        return [(float(2 + i), None) for i in range(RUNS + 1)]
    if name == "cubes":
        sys.path.insert(0, str(HERE.parent / "tests"))
        import session_scenes
        views = session_scenes.orbit_views(stage, RUNS + 1, 16 / 9)
        return [(None, v) for v in views]
    return [(None, None)] * (RUNS + 1)


def _render(session, change, **kw):
    frame, view = change
    if view is None:
        return session.render(frame=frame, **kw)
    return session.render(view_matrix=view[0], projection_matrix=view[1], frame=frame, **kw)


def measure(name, stage, size, preset, images, image_sizes, form="compute"):
    from lantern.engine import RenderSettings, Session
    from lantern.core.presets import preset as find_preset
    k = find_preset(preset).supersample
    changes = _changes(name, stage)
    settings = RenderSettings(width=size[0], height=size[1], preset=preset, **FORMS[form])
    with Session(stage, settings) as s:
        t0 = time.perf_counter()
        first = _render(s, changes[0])
        first_ms, first_load_ms = (time.perf_counter() - t0) * 1e3, first.timings["load"] * 1e3
        walls, results = [], []
        for change in changes[1:]:
            t0 = time.perf_counter()
            results.append(_render(s, change))
            walls.append(time.perf_counter() - t0)
        last = results[-1]
        # Into the caller's buffer, reused (as the engine host's shared memory is):
        # no first touch of new pages per frame (the walls above read into new arrays).
        buffer = np.zeros((size[1], size[0], 4), np.float32)
        into = []
        for change in changes[1:]:
            t0 = time.perf_counter()
            _render(s, change, out=buffer)
            into.append(time.perf_counter() - t0)
        s.configure(readback="half")
        half = [_render(s, c).timings["readback"] for c in changes[1:]]
        s.configure(readback="float32")
        queued = None
        if name == "crowd":               # a sequence: frames pipelined behind fences
            t0 = time.perf_counter()
            n = sum(1 for _ in s.render_frames([c[0] for c in changes[1:]]))
            queued = (time.perf_counter() - t0) / n
        size_name = f"{size[0]}x{size[1]}"
        if images is not None and preset == "medium" and size_name in image_sizes:
            np.savez_compressed(images / f"{name}_{size_name}.npz", rgba=last.rgba)
    med = statistics.median
    return {
        "scene": name, "size": list(size), "preset": preset, "supersample": k, "form": form,
        "image": last.rgba,
        "first_frame_ms": first_ms, "first_load_ms": first_load_ms,
        "frame_ms": med(walls) * 1e3,
        "frame_into_buffer_ms": med(into) * 1e3,
        "readback_ms": med(r.timings["readback"] for r in results) * 1e3,
        "readback_half_ms": med(half) * 1e3,
        "sequence_frame_ms": None if queued is None else queued * 1e3,
        "cpu_ms": med(r.stats["cpu_seconds"] for r in results) * 1e3,
        "cpu_pass_ms": {p: v * 1e3 for p, v in last.timings.items()
                        if p in last.gpu_timings},
        "gpu_pass_ms": {p: v * 1e3 for p, v in last.gpu_timings.items()},
        "gpu_ms": sum(last.gpu_timings.values()) * 1e3,
        "gl": {key: last.stats[key] for key in
               ("gl_renderer", "gl_version", "gl_requested", "gl_path", "readback_mode")},
    }


def _renderer() -> str:
    """The GL renderer a session gets here."""
    from lantern.engine.gpu.context import GLContext
    context = GLContext()
    try:
        return context.ctx.info["GL_RENDERER"]
    finally:
        context.release()


def run(folder, sizes, presets, json_path, images, everything, image_sizes=("640x360",),
        forms=tuple(FORMS), lights=False, scenes=SCENES):
    from lantern.engine.usd.opening import open_stage
    if images is not None:
        images.mkdir(parents=True, exist_ok=True)
    rows, gl = [], None
    software = "llvmpipe" in _renderer()
    for name in scenes:
        stage = open_stage(str(folder / f"{name}.usdc"))
        for size_name in sizes:
            size = SIZES[size_name]
            for preset in presets:
                from lantern.core.presets import preset as find_preset
                k = find_preset(preset).supersample
                if not everything and size[0] * size[1] * k * k > LLVMPIPE_PIXELS \
                        and software:
                    print(f"  {name:<6} {size_name:>9} {preset:<7} skipped on llvmpipe "
                          f"({size[0] * k}x{size[1] * k} drawn; --all runs it)", flush=True)
                    continue
                for form in forms:          # the images: of the first form
                    row = measure(name, stage, size, preset,
                                  images if form == forms[0] else None, image_sizes, form)
                    gl = row["gl"]
                    rows.append(row)
                    _print(row)
    if lights:
        rows += many_lights(folder, forms)
    if gl:
        print(f"GL: {gl['gl_renderer']}, {gl['gl_version']} (asked {gl['gl_requested']}); "
              f"{gl['gl_path']}; read-back {gl['readback_mode']}")
    for row in rows:
        row.pop("image", None)
    if json_path:
        payload = {"date": time.strftime("%Y-%m-%d"), "gl": gl, "rows": rows}
        tmp = f"{json_path}.tmp"
        with open(tmp, "w") as f:
            json.dump(payload, f, indent=1)
        os.replace(tmp, json_path)
        print(f"wrote {json_path}")


def many_lights(folder, forms):
    """The many-lights scenes at 1920x1080, medium: frame and lights-pass times against
    one light, and the error against the exact sum on a 48 x 27 grid of pixels."""
    from lantern.engine.usd.opening import open_stage
    w, h = LIGHTS_SIZE
    step = 40
    cols, rows_ = np.arange(step // 2, w, step), np.arange(step // 2, h, step)
    x = ((cols + 0.5) / w - 0.5) * LIGHTS_EXTENT
    y = -((rows_ + 0.5) / h - 0.5) * LIGHTS_EXTENT * h / w
    X, Y = np.meshgrid(x, y)

    def exact(positions, power):
        total = np.zeros_like(X)
        for px, py, pz in positions:
            total += pz / ((X - px) ** 2 + (Y - py) ** 2 + pz * pz) ** 1.5
        return total * power

    out, one = [], {}
    print(f"many lights at {w}x{h}, medium: error against the exact sum on "
          f"{X.size} pixels; times against one light of the same form")
    for count in LIGHT_COUNTS:
        stage = open_stage(str(folder / f"lights_{count}.usdc"))
        truth = exact(light_positions(count), 1.0 / count)
        for form in forms:
            # The raster form lights as `volumes` does. 16,384 volumes are 16,384 draws:
            # minutes a frame on llvmpipe, and 256 took 141 ms on an H100 (docs/gpu.md).
            if form == "raster" or (form == "volumes" and count > 256):
                continue
            row = measure(f"lights_{count}", stage, LIGHTS_SIZE, "medium", None, (), form)
            got = row["image"][rows_][:, cols, 0].astype(np.float64)
            if count == 1:
                one[form] = (row, got / truth)          # the plane's radiance per irradiance
            base, scale = one[form]
            error = np.abs(got / (truth * np.median(scale)) - 1)
            row.update(error_max=float(error.max()), error_mean=float(error.mean()),
                       times_one=row["frame_into_buffer_ms"] / base["frame_into_buffer_ms"])
            out.append(row)
            lights_ms = row["gpu_pass_ms"].get("lights", 0.0) + \
                row["gpu_pass_ms"].get("light_cull", 0.0)
            print(f"  {count:>6} lights {form:<8} frame {row['frame_into_buffer_ms']:8.1f} ms "
                  f"({row['times_one']:5.2f} x one light) | light cull + lights GPU "
                  f"{lights_ms:8.1f} ms | error max {100 * row['error_max']:.3f}%, mean "
                  f"{100 * row['error_mean']:.4f}% | a new Session's first frame "
                  f"{row['first_frame_ms']:7.0f} ms, its stage read {row['first_load_ms']:7.0f} ms",
                  flush=True)
    return out


def _print(row):
    heavy = sorted(row["gpu_pass_ms"].items(), key=lambda kv: -kv[1])[:3]
    seq = f", in a sequence {row['sequence_frame_ms']:.1f}" if row["sequence_frame_ms"] else ""
    print(f"  {row['scene']:<6} {row['size'][0]}x{row['size'][1]:<5} {row['preset']:<7}"
          f" {row['form']:<8}"
          f" frame {row['frame_into_buffer_ms']:8.1f} ms into a buffer, "
          f"{row['frame_ms']:8.1f} into a new array{seq} | GPU {row['gpu_ms']:7.1f} | CPU "
          f"{row['cpu_ms']:6.1f} | readback f32 {row['readback_ms']:5.1f} "
          f"({100 * row['readback_ms'] / row['frame_ms']:4.1f}%), f16 "
          f"{row['readback_half_ms']:5.1f} | heaviest: "
          + ", ".join(f"{p} {v:.1f}" for p, v in heavy), flush=True)


def compare(a: pathlib.Path, b: pathlib.Path):
    """Pixels of two machines' images: the share differing by more than 1e-2."""
    for path in sorted(a.glob("*.npz")):
        other = b / path.name
        if not other.is_file():
            print(f"  {path.name}: missing in {b}")
            continue
        x, y = np.load(path)["rgba"], np.load(other)["rgba"]
        diff = np.abs(x.astype(np.float64) - y).max(axis=-1)
        print(f"  {path.stem:<22} max {np.nanmax(diff):.4f}, "
              f"{100 * np.mean(diff > 1e-2):.3f}% of pixels > 1e-2")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("prepare").add_argument("folder", type=pathlib.Path)
    r = sub.add_parser("run")
    r.add_argument("folder", type=pathlib.Path)
    r.add_argument("--sizes", nargs="+", default=list(SIZES), choices=list(SIZES))
    r.add_argument("--presets", nargs="+", default=list(PRESETS), choices=PRESETS)
    r.add_argument("--json")
    r.add_argument("--images", type=pathlib.Path)
    r.add_argument("--image-sizes", nargs="+", default=["640x360"], choices=list(SIZES))
    r.add_argument("--all", action="store_true", help="also the largest targets on llvmpipe")
    r.add_argument("--forms", nargs="+", default=list(FORMS), choices=list(FORMS))
    r.add_argument("--lights", action="store_true", help="also the many-lights scenes")
    r.add_argument("--scenes", nargs="*", default=list(SCENES), choices=SCENES)
    c = sub.add_parser("compare")
    c.add_argument("a", type=pathlib.Path)
    c.add_argument("b", type=pathlib.Path)
    if len(sys.argv) == 1:
        folder = HERE.parent / "out" / "gpu_scenes"
        prepare(folder)
        run(folder, ["640x360", "1920x1080"], ["low", "medium"], None, None, False, lights=True)
        return
    args = parser.parse_args()
    if args.command == "prepare":
        prepare(args.folder)
    elif args.command == "run":
        run(args.folder, args.sizes, args.presets, args.json, args.images, args.all,
            args.image_sizes, args.forms, args.lights, args.scenes)
    else:
        compare(args.a, args.b)


if __name__ == "__main__":
    main()
