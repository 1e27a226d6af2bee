"""The `lantern` command line: export .blend files to USD, render USD (or .blend) to images.

bpy is imported only for work that reads .blend files, so `lantern render scene.usd`
runs without Blender, on usd-core. Batch export runs each file in its own process:
a file that crashes Blender then fails alone, and the batch goes on and reports it.
"""
import argparse
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

USD_SUFFIXES = (".usd", ".usda", ".usdc")
IMAGE_SUFFIXES = (".exr", ".png")


def _parse_size(text):
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size must look like 640x360, not {text!r}")
    if width <= 0 or height <= 0:
        raise argparse.ArgumentTypeError(f"--size must be positive, not {text!r}")
    return width, height


def _build_parser():
    parser = argparse.ArgumentParser(prog="lantern", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)

    export = commands.add_parser("export", help="export .blend files to USD")
    export.add_argument("blends", nargs="+", metavar="scene.blend")
    export.add_argument("-o", "--output", required=True,
                        help="a .usd/.usda/.usdc file for one input, or a folder for several")
    export.add_argument("-j", "--jobs", type=int, default=max(1, (os.cpu_count() or 2) // 2),
                        help="files exported at once in a batch")
    export.add_argument("--format", choices=("usda", "usdc", "usd"), default="usdc",
                        help="file format of a batch's outputs (default usdc)")
    export.add_argument("--textures", choices=("reference", "copy"), default="reference",
                        help="reference images where they are, or copy them beside the USD file")
    export.add_argument("--max-influences", type=int, default=None, metavar="N",
                        help="keep the N largest joint influences per vertex (default: all)")

    render = commands.add_parser("render", help="render a USD stage or a .blend file")
    render.add_argument("scene", metavar="scene.usd|scene.blend")
    render.add_argument("-o", "--output", required=True, help="an .exr (scene linear) or .png (sRGB)")
    render.add_argument("--frame", type=float, default=None, help="time code / frame to render")
    render.add_argument("--frames", default=None, metavar="A:B",
                        help="render frames A..B; '####' in -o becomes the zero-padded frame, "
                             "an -o ending in .gif writes one animated preview")
    render.add_argument("--size", type=_parse_size, default=None, metavar="WxH")
    render.add_argument("--preset", default="medium", help="low, medium, high or ultra")
    # Blender's colour management for .png/.gif outputs (an .exr stays scene linear).
    render.add_argument("--view", default="Standard",
                        help="view transform: Standard, AgX, Filmic, Khronos PBR Neutral, ...")
    render.add_argument("--look", default=None, help="a look of that view, e.g. Punchy")
    render.add_argument("--exposure", type=float, default=0.0, help="exposure in stops")
    return parser


def main(argv=None):
    args = _build_parser().parse_args(argv)
    if args.command == "export":
        return _export(args)
    return _render(args)


# --- export -----------------------------------------------------------------------------

def _export(args):
    for blend in args.blends:
        if not blend.lower().endswith(".blend"):
            print(f"lantern export: {blend}: not a .blend file", file=sys.stderr)
            return 2
    if len(args.blends) == 1 and args.output.lower().endswith(USD_SUFFIXES):
        return _export_one(args.blends[0], args.output, args)
    if args.output.lower().endswith(USD_SUFFIXES):
        print("lantern export: several inputs need a folder for -o", file=sys.stderr)
        return 2
    return _export_batch(args)


def _export_one(blend, out_path, args):
    """Export in this process. Prints warnings; returns the exit status."""
    from .exporters import ExportError, ExportOptions, export_blend
    if args.max_influences is not None and args.max_influences < 1:
        print("lantern export: --max-influences must be at least 1", file=sys.stderr)
        return 2
    options = ExportOptions(textures=args.textures, max_influences=args.max_influences)
    try:
        report = export_blend(blend, out_path, options)
    except ExportError as error:
        print(f"lantern export: {error}", file=sys.stderr)
        return 1
    for warning in report.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    counts = ", ".join(f"{n} {kind}" for kind, n in report.counts.items() if n)
    print(f"{blend} -> {report.path} ({counts}; {report.seconds:.2f} s)")
    return 0


def _export_batch(args):
    from rich.console import Console
    from rich.progress import Progress
    from rich.table import Table

    os.makedirs(args.output, exist_ok=True)
    jobs = []
    for blend in args.blends:
        stem = os.path.splitext(os.path.basename(blend))[0]
        jobs.append((blend, os.path.join(args.output, f"{stem}.{args.format}")))
    if len({out for _, out in jobs}) != len(jobs):
        print("lantern export: two inputs share a file name; their outputs would collide",
              file=sys.stderr)
        return 2

    def run(job):
        blend, out_path = job
        start = time.perf_counter()
        # Each file in its own process: a crash in Blender fails that file only.
        command = [sys.executable, "-m", "lantern", "export", blend, "-o", out_path,
                   "--textures", args.textures]
        if args.max_influences is not None:
            command += ["--max-influences", str(args.max_influences)]
        proc = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        warnings = [line for line in proc.stderr.splitlines() if line.startswith("warning: ")]
        if proc.returncode == 0:
            return blend, "ok", seconds, len(warnings), out_path
        reason = [line for line in proc.stderr.splitlines()
                  if line.strip() and not line.startswith("warning: ")]
        if proc.returncode < 0:
            reason.append(f"Blender crashed (signal {-proc.returncode})")
        return blend, "failed", seconds, len(warnings), (reason[-1] if reason else "unknown error")

    results = []
    console = Console(stderr=True)
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task("exporting", total=len(jobs))
        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            for result in pool.map(run, jobs):
                results.append(result)
                progress.advance(task)

    table = Table(title="lantern export")
    for column in ("file", "status", "seconds", "warnings", "output / reason"):
        table.add_column(column, overflow="fold")
    for blend, status, seconds, n_warnings, detail in results:
        style = "green" if status == "ok" else "red"
        table.add_row(os.path.basename(blend), f"[{style}]{status}[/]", f"{seconds:.2f}", str(n_warnings), detail)
    Console(width=max(120, Console().width)).print(table)
    failed = sum(1 for r in results if r[1] != "ok")
    print(f"{len(results) - failed} exported, {failed} failed")
    return 1 if failed else 0


# --- render -----------------------------------------------------------------------------

def _render(args):
    if args.frames is not None:
        return _render_sequence(args)
    if not args.output.lower().endswith(IMAGE_SUFFIXES):
        print(f"lantern render: {args.output}: the output must be .exr or .png", file=sys.stderr)
        return 2
    stage, status = _open_scene(args.scene)
    if stage is None:
        return status
    colour = _colour(args)  # a bad --view or --look fails before rendering
    width, height = args.size if args.size else (None, None)

    from .engine import RenderSettings, render_stage
    from .engine.image_io import write_image
    try:
        settings = RenderSettings(width=width, height=height, frame=args.frame, preset=args.preset)
    except ValueError as error:
        print(f"lantern render: {error}", file=sys.stderr)
        return 2
    try:
        result = render_stage(stage, settings)
    except (ValueError, RuntimeError, OSError) as error:  # pxr's errors are RuntimeErrors
        print(f"lantern render: {args.scene}: {error}", file=sys.stderr)
        return 1
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    write_image(args.output, result.rgba, **colour)
    height_px, width_px = result.rgba.shape[:2]
    print(f"{args.scene} -> {args.output} ({width_px}x{height_px}, "
          f"{result.timings.get('total', 0.0) * 1000:.1f} ms)")
    return 0


def _colour(args):
    """The view settings for image writers; an unknown view or look exits with status 2."""
    from .engine.color import ColorManagementError, check
    try:
        check(args.view, args.look, args.exposure)
    except ColorManagementError as error:
        print(f"lantern render: {error}", file=sys.stderr)
        raise SystemExit(2)
    return dict(view=args.view, look=args.look, exposure=args.exposure)


def _open_scene(path):
    """(stage, 0), or (None, exit status) after saying why: a .blend is exported into
    memory (Blender's own pxr), a USD file is opened (usd-core, no bpy)."""
    if not os.path.isfile(path):
        print(f"lantern render: {path}: no such file", file=sys.stderr)
        return None, 1
    if path.lower().endswith(".blend"):
        stage = _stage_from_blend(path)
        return (stage, 0) if stage is not None else (None, 1)
    if not path.lower().endswith(USD_SUFFIXES):
        print(f"lantern render: {path}: expected a .usd, .usda, .usdc or .blend file",
              file=sys.stderr)
        return None, 2
    from pxr import Usd
    try:
        return Usd.Stage.Open(path), 0
    except RuntimeError as error:  # pxr's errors: an unreadable or invalid layer
        print(f"lantern render: {path}: {error}", file=sys.stderr)
        return None, 1


def _frame_path(pattern, frame):
    """'####' (any run of #) -> the frame number zero-padded to that width."""
    import re
    return re.sub(r"#+", lambda m: f"{int(round(frame)):0{len(m.group(0))}d}", pattern, count=1)


def _render_sequence(args):
    try:
        first, last = (float(x) for x in args.frames.split(":"))
    except ValueError:
        print(f"lantern render: --frames must look like 1:24, not {args.frames!r}", file=sys.stderr)
        return 2
    gif = args.output.lower().endswith(".gif")
    if not gif and (not args.output.lower().endswith(IMAGE_SUFFIXES) or "#" not in args.output):
        print(f"lantern render: {args.output}: a sequence needs '####' in an .exr/.png name, "
              "or a .gif", file=sys.stderr)
        return 2
    stage, status = _open_scene(args.scene)
    if stage is None:
        return status
    colour = _colour(args)  # a bad --view or --look fails before rendering
    from .engine import RenderSettings
    from .engine.api import render_sequence
    from .engine.image_io import write_animation, write_image
    width, height = args.size if args.size else (None, None)
    settings = RenderSettings(width=width, height=height, preset=args.preset)
    frames, seen = [], set()
    try:
        for frame, result in render_sequence(stage, first, last, settings):
            for warning in result.warnings:
                if warning not in seen:
                    seen.add(warning)
                    print(f"warning: {warning}", file=sys.stderr)
            if gif:
                frames.append(result.rgba)
                continue
            path = _frame_path(args.output, frame)
            os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
            write_image(path, result.rgba, **colour)
            print(f"{args.scene} frame {frame:g} -> {path} "
                  f"({result.timings.get('total', 0.0) * 1000:.1f} ms)")
    except (ValueError, RuntimeError, OSError) as error:
        print(f"lantern render: {args.scene}: {error}", file=sys.stderr)
        return 1
    if gif:
        os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
        write_animation(args.output, frames, stage.GetFramesPerSecond() or 24.0, **colour)
        print(f"{args.scene} frames {first:g}:{last:g} -> {args.output}")
    return 0


def _stage_from_blend(blend):
    """Export a .blend into an in-memory stage, in this process (with Blender's own pxr)."""
    from .exporters import ExportError, stage_from_blend
    try:
        stage, report = stage_from_blend(blend)
    except ExportError as error:
        print(f"lantern render: {error}", file=sys.stderr)
        return None
    for warning in report.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    return stage


if __name__ == "__main__":
    raise SystemExit(main())
