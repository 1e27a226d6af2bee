"""The `lantern` command line: export .blend files to USD, render USD (or .blend) to images.

bpy is imported only for work that reads .blend files, so `lantern render scene.usd`
runs without Blender, on usd-core. Batch export and sequences run as tasks (farm/):
each exported file in its own Blender process (a file that crashes Blender fails alone,
and the batch goes on and reports it), and frames in chunks on worker processes that
keep the stage loaded; on this machine, or on a Dask cluster with --scheduler.

Every failure ends with one line naming the file, prim or option and the reason, and
an exit status: 2 when the command line is wrong, 1 when an input cannot be read or
exported or rendered or an output cannot be written, 130 when interrupted (Ctrl-C).
`--debug` shows the traceback of an unexpected error instead of one line.
"""
import argparse
import functools
import logging
import math
import os
import sys
import time

from .core import interrupt
from .core.text import error_text, one_line
from .core.version import installed_version

USD_SUFFIXES = (".usd", ".usda", ".usdc")
IMAGE_SUFFIXES = (".exr", ".png")
# The largest texture side OpenGL implementations guarantee at most (llvmpipe's limit).
MAX_SIDE = 16384

# Local worker processes for a sequence: one. On 2 cores llvmpipe already draws with
# every core, and two measured no faster and costlier in CPU (bench/bench_distributed.py).
RENDER_PROCESSES = 1

USAGE, FAILED, INTERRUPTED = 2, 1, interrupt.INTERRUPTED
EXIT_STATUSES = """exit status:
  0    done
  1    an input could not be read, exported or rendered, or an output not written
  2    the command line is wrong (unknown option, bad value, wrong kind of path)
  130  interrupted (Ctrl-C)"""


class CommandError(Exception):
    """Ends the command with one line and `status`."""

    def __init__(self, message, status=FAILED):
        super().__init__(message)
        self.status = status


def _usage(message):
    return CommandError(message, USAGE)


# --- arguments --------------------------------------------------------------------------

def _parse_size(text):
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size must look like 640x360, not {text!r}")
    if width <= 0 or height <= 0:
        raise argparse.ArgumentTypeError(f"--size must be positive, not {text!r}")
    if width > MAX_SIDE or height > MAX_SIDE:
        raise argparse.ArgumentTypeError(f"--size {text}: each side must be at most {MAX_SIDE}")
    return width, height


def _number(text):
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(text)
    return value


def _parse_frames(text):
    """'A:B' or 'A:B:STEP' -> the frames A, A+STEP, ... up to B (inclusive)."""
    parts = text.split(":")
    try:
        if len(parts) not in (2, 3):
            raise ValueError(text)
        first, last = _number(parts[0]), _number(parts[1])
        step = _number(parts[2]) if len(parts) == 3 else 1.0
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames must look like 1:24 or 1:24:2, not {text!r}")
    if step <= 0:
        raise argparse.ArgumentTypeError(f"--frames {text}: the step must be positive")
    if last < first:
        raise argparse.ArgumentTypeError(f"--frames {text}: the last frame comes before the first")
    count = int(math.floor((last - first) / step + 1e-9)) + 1
    return [first + i * step for i in range(count)]


class _Version(argparse.Action):
    """--version, looked up only when asked for (importlib.metadata costs a plain
    render 20 ms)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="show the version and exit"):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"lantern {installed_version()}")     # on stdout, as argparse's own
        parser.exit()


def _build_parser(argv=None):
    parser = argparse.ArgumentParser(
        prog="lantern", description=__doc__.splitlines()[0], epilog=EXIT_STATUSES,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action=_Version)
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true",
                        help="show the traceback of an unexpected error")
    farm = argparse.ArgumentParser(add_help=False)
    farm.add_argument("--scheduler", default=os.environ.get("LANTERN_SCHEDULER") or None,
                      metavar="ADDRESS",
                      help="run the tasks on this Dask scheduler (tcp://HOST:PORT), or on "
                           "an embedded Dask LocalCluster ('local'); default: "
                           "$LANTERN_SCHEDULER, else processes on this machine")
    farm.add_argument("--status-fd", type=int, default=None, metavar="FD",
                      help="write one line per state of a batch or sequence to this file "
                           "descriptor ('running' once the first tasks are on the workers, "
                           "'finished'), for the tools that drive lantern")
    farm.add_argument("--collect", action="store_true",
                      help="workers send the outputs back and this process writes them "
                           "(for outputs on a folder the workers do not share)")
    farm.add_argument("--resume", action="store_true",
                      help="skip outputs that exist and are newer than their input")
    commands = parser.add_subparsers(dest="command", required=True)

    export = commands.add_parser("export", parents=[common, farm],
                                 help="export .blend files to USD",
                                 epilog=EXIT_STATUSES,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    export.add_argument("blends", nargs="+", metavar="scene.blend")
    export.add_argument("-o", "--output", required=True,
                        help="a .usd/.usda/.usdc file for one input, or a folder")
    export.add_argument("-j", "--jobs", type=int, default=max(1, (os.cpu_count() or 2) // 2),
                        help="files exported at once in a batch on this machine")
    export.add_argument("--format", choices=("usda", "usdc", "usd"), default="usdc",
                        help="file format of a batch's outputs (default usdc)")
    export.add_argument("--textures", choices=("reference", "copy"), default="reference",
                        help="reference images where they are, or copy them beside the USD file")
    export.add_argument("--max-influences", type=int, default=None, metavar="N",
                        help="keep the N largest joint influences per vertex (default: all)")

    render = commands.add_parser("render", parents=[common, farm],
                                 help="render a USD stage or a .blend file",
                                 epilog=EXIT_STATUSES,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    render.add_argument("scenes", nargs="+", metavar="scene.usd|scene.blend")
    render.add_argument("-o", "--output", required=True,
                        help="an .exr (scene linear) or .png (sRGB); for --frames, a name "
                             "with '####' (the frame) or a .gif; for several scenes, a "
                             "folder (outputs named after the inputs; for one, end it "
                             "with /)")
    render.add_argument("--format", choices=("png", "exr"), default="png",
                        help="image format of the outputs written into a folder (default png)")
    render.add_argument("--timings", action="store_true",
                        help="print the phases of the render: process start to main, "
                             "imports, GL context, stage open, scene read, programs, "
                             "uploads, first frame, encode and write")
    render.add_argument("--frame", type=_number, default=None, help="time code / frame to render")
    render.add_argument("--frames", type=_parse_frames, default=None, metavar="A:B[:STEP]",
                        help="render frames A..B every STEP (default 1); '####' in -o becomes "
                             "the zero-padded frame, an -o ending in .gif writes one preview")
    render.add_argument("--size", type=_parse_size, default=None, metavar="WxH",
                        help=f"image size, each side at most {MAX_SIDE}")
    render.add_argument("--preset", default="medium", help="low, medium, high or ultra")
    render.add_argument("--camera", default=None, metavar="PRIM",
                        help="the camera prim to render through (default: the stage's "
                             "render settings camera, else the first camera)")
    # Blender's colour management for .png/.gif outputs (an .exr stays scene linear):
    # the scene's own (exported on /Render/Settings), unless given here.
    render.add_argument("--view", default=None,
                        help="view transform: Standard, AgX, Filmic, Khronos PBR Neutral, ... "
                             "(default: the scene's, else Standard)")
    render.add_argument("--look", default=None,
                        help="a look of that view, e.g. Punchy (default: the scene's, with its view)")
    render.add_argument("--exposure", type=float, default=None,
                        help="exposure in stops (default: the scene's, with its view, else 0)")
    render.add_argument("--chunk", type=int, default=None, metavar="N",
                        help="frames per task of a sequence (default: chosen from the "
                             "measured cold and warm render times)")
    render.add_argument("-j", "--jobs", type=int, default=RENDER_PROCESSES,
                        help="worker processes for a sequence on this machine "
                             f"(default {RENDER_PROCESSES})")
    from .cli_overlays import add_options as add_overlay_options
    add_overlay_options(render)

    # `lantern compare` brings its package's imports: a render or export goes without.
    if _command(argv) not in ("render", "export"):
        from .compare.command import add_parser as add_compare_parser
        add_compare_parser(commands, [common], _parse_size, EXIT_STATUSES,
                           argparse.RawDescriptionHelpFormatter)
    return parser


def _command(argv):
    """The sub-command named on the command line (its first word that is no option)."""
    words = sys.argv[1:] if argv is None else argv
    return next((w for w in words if not w.startswith("-")), None)


def _check_farm(args):
    if args.scheduler is not None and args.scheduler != "local" and "://" not in args.scheduler:
        raise _usage(f"--scheduler {args.scheduler}: must be a Dask scheduler address like "
                     "tcp://HOST:8786, or 'local'")
    if args.jobs < 1:
        raise _usage("-j must be at least 1")


def main(argv=None):
    started = (_seconds_since_start(), time.perf_counter())
    previous = interrupt.exit_at_once()      # before the parser's (lazy) imports
    try:
        return _main(argv, started)
    finally:
        interrupt.restore(previous)


def _main(argv, started):
    args = _build_parser(argv).parse_args(argv)
    args.started = started
    # The exporter logs its warnings and the CLI prints them: keep Python's last-resort
    # handler from printing each a second time.
    logging.getLogger("lantern").addHandler(logging.NullHandler())
    if args.debug:      # what the engine only logs (a program cache entry rebuilt)
        engine_log = logging.getLogger("lantern.engine")
        engine_log.setLevel(logging.DEBUG)
        engine_log.addHandler(logging.StreamHandler(sys.stderr))
    try:
        # From here Ctrl-C is a KeyboardInterrupt: workers are closed and half-written
        # files removed on the way out.
        interrupt.raise_keyboard_interrupt()
        if args.command == "compare":
            from .compare.command import run as compare
            return compare(args, _usage, CommandError)
        return _export(args) if args.command == "export" else _render(args)
    except CommandError as error:
        _fail(args, str(error))
        return error.status
    except KeyboardInterrupt:
        _fail(args, "interrupted")
        return INTERRUPTED
    except Exception as error:  # a bug: one line, or the traceback with --debug
        if args.debug:
            raise
        _fail(args, _internal_error(error))
        return FAILED


def _internal_error(error):
    return (f"internal error: {type(error).__name__}: {one_line(error_text(error))} "
            "(--debug shows the traceback)")


def _fail(args, message):
    print(f"lantern {args.command}: {message}", file=sys.stderr, flush=True)


def _check_output(path, kinds, what="output"):
    """Fails before any work when `path` cannot be written: wrong kind, a directory, or
    a folder that cannot be made or written."""
    if not path.lower().endswith(kinds):
        raise _usage(f"{path}: the {what} must be {' or '.join(kinds)}")
    if os.path.isdir(path):
        raise _usage(f"{path}: is a directory, not a file name")
    _check_folder(os.path.dirname(os.path.abspath(path)))


def _check_folder(folder):
    """The folder, or its nearest existing ancestor (missing folders are made), must be a
    writable directory."""
    existing = folder
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        raise CommandError(f"{folder}: cannot be made: {existing} is not a directory")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise CommandError(f"{folder}: {existing} is not writable")


def _make_folder(folder):
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise CommandError(f"{folder}: cannot be made: {error.strerror}")


def _print_warnings(warnings, seen):
    for warning in warnings:
        if warning not in seen:
            seen.add(warning)
            print(f"warning: {warning}", file=sys.stderr)


# --- export -----------------------------------------------------------------------------

def _export(args):
    for blend in args.blends:
        if not blend.lower().endswith(".blend"):
            raise _usage(f"{blend}: not a .blend file")
    if args.max_influences is not None and args.max_influences < 1:
        raise _usage("--max-influences must be at least 1")
    _check_farm(args)
    single = args.output.lower().endswith(USD_SUFFIXES)
    if args.collect and args.textures == "reference":
        raise _usage("--collect needs --textures copy: referenced images would be named "
                     "relative to the worker's folder, not the output's")
    if single and len(args.blends) > 1:
        raise _usage(f"{args.output}: several inputs need a folder for -o")
    if not single and os.path.splitext(args.output)[1] and not os.path.isdir(args.output):
        raise _usage(f"{args.output}: -o must be a .usd, .usda or .usdc file, or a folder")
    if single and (args.scheduler is not None or args.collect or args.resume):
        raise _usage("--scheduler, --collect and --resume are for a batch: give -o a folder")
    if single:
        _check_output(args.output, USD_SUFFIXES)
        return _export_one(args.blends[0], args.output, args)
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        raise _usage(f"{args.output}: is a file, not a folder")
    _check_folder(os.path.abspath(args.output))
    return _export_batch(args)


def _export_one(blend, out_path, args):
    """Export in this process. Prints warnings; returns the exit status."""
    if not os.path.isfile(blend):
        raise CommandError(f"{blend}: no such file")
    from .exporters import ExportError, ExportOptions, export_blend
    options = ExportOptions(textures=args.textures, max_influences=args.max_influences)
    try:
        report = export_blend(blend, out_path, options)
    except ExportError as error:
        raise CommandError(one_line(str(error)))
    except OSError as error:
        raise CommandError(f"{out_path}: cannot be written: {error.strerror or error}")
    _print_warnings(report.warnings, set())
    counts = ", ".join(f"{n} {kind}" for kind, n in report.counts.items() if n)
    print(f"{blend} -> {report.path} ({counts}; {report.seconds:.2f} s)")
    return 0


def _export_batch(args):
    from .farm.batch import FarmError, export_batch
    from .farm.options import ExportBatchOptions
    jobs = []
    for blend in args.blends:
        stem = os.path.splitext(os.path.basename(blend))[0]
        jobs.append((blend, os.path.join(args.output, f"{stem}.{args.format}")))
    if len({out for _, out in jobs}) != len(jobs):
        raise _usage("two inputs share a file name; their outputs would collide")
    _make_folder(args.output)
    try:
        return export_batch(ExportBatchOptions(
            scheduler=args.scheduler, jobs=args.jobs, collect=args.collect, resume=args.resume,
            status=_status_writer(args), textures=args.textures,
            max_influences=args.max_influences), jobs)
    except FarmError as error:
        raise CommandError(str(error))


def _status_writer(args):
    """--status-fd: a function writing one state per line to that descriptor."""
    if args.status_fd is None:
        return None

    def write(state):
        try:
            os.write(args.status_fd, f"{state}\n".encode())
        except OSError:          # the reader went away: the work goes on
            pass
    return write


# --- render -----------------------------------------------------------------------------

def _render(args):
    if len(args.scenes) > 1 or _is_folder(args.output):
        return _render_files(args)
    args.scene = args.scenes[0]
    if args.frames is not None and args.frame is not None:
        raise _usage("--frame and --frames cannot be used together")
    if args.frames is None:
        _check_output(args.output, IMAGE_SUFFIXES)
    elif args.output.lower().endswith(".gif"):
        _check_output(args.output, (".gif",))
    else:
        _check_output(args.output, IMAGE_SUFFIXES)
        if "#" not in args.output:
            raise _usage(f"{args.output}: a sequence needs '####' in an .exr/.png name, or a .gif")
    _check_render_options(args)
    if not os.path.isfile(args.scene):
        raise CommandError(f"{args.scene}: no such file")
    is_blend = args.scene.lower().endswith(".blend")
    if not is_blend and not args.scene.lower().endswith(USD_SUFFIXES):
        raise _usage(f"{args.scene}: expected a .usd, .usda, .usdc or .blend file")
    if is_blend:
        from . import exporters  # noqa: F401  (Blender's pxr before the engine's)
    _check_preset(args.preset)
    _check_colour(args)

    if args.frames is None:
        phases = _Phases(args.started)
        _import_render_path()
        phases.mark("imports")
        return _render_frame(args, is_blend, phases)
    # A sequence's workers start first, and get ready while the stage is read here.
    from .farm.batch import FarmError, open_render_runner
    try:
        runner = open_render_runner(args.scheduler, args.jobs)
    except FarmError as error:
        raise CommandError(str(error))
    try:
        stage = _stage_from_blend(args.scene) if is_blend else _open_usd(args.scene)
        _check_camera(stage, args)
        args.colour = _colour(stage, args)
        from .cli_overlays import from_args as overlays_from_args
        args.overlays = overlays_from_args(args, stage, CommandError)
        # A .blend's stage was exported here: the workers get it as text.
        text = stage.GetRootLayer().ExportToString() if is_blend else None
    except BaseException:
        runner.close(interrupted=True)
        raise
    return _render_sequence(stage, args, runner, text)


def _check_render_options(args):
    _check_farm(args)
    if args.timings and args.frames is not None:
        raise _usage("--timings is for single frames, not --frames")
    if args.frames is None and (args.scheduler is not None or args.collect or args.resume
                                or args.chunk is not None):
        raise _usage("--scheduler, --collect, --resume and --chunk are for a sequence "
                     "(--frames)")
    if args.chunk is not None and args.chunk < 1:
        raise _usage("--chunk must be at least 1")
    if args.camera is not None and not args.camera.startswith("/"):
        raise _usage(f"--camera {args.camera}: must be an absolute prim path, like /root/Camera")
    from .cli_overlays import check as check_overlays
    check_overlays(args, _usage, CommandError)


def _is_folder(output):
    """-o names a folder for one scene when it ends with a separator (an image name that
    is a directory stays a usage error); several scenes always take a folder."""
    return output.endswith(("/", os.sep))


def _render_files(args):
    """Several scenes, one image each, into the folder -o, in this process: one GL
    context and one program cache for all. A file that cannot be read or rendered is
    one line, and the others go on; the exit status is then 1."""
    if args.frames is not None:
        raise _usage("--frames renders one scene: give several scenes one frame each")
    _check_render_options(args)
    for scene in args.scenes:
        if not scene.lower().endswith(USD_SUFFIXES + (".blend",)):
            raise _usage(f"{scene}: expected a .usd, .usda, .usdc or .blend file")
    if args.output.lower().endswith(IMAGE_SUFFIXES + (".gif",)):
        raise _usage(f"{args.output}: several scenes need a folder for -o")
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        raise _usage(f"{args.output}: is a file, not a folder")
    jobs = [(scene, os.path.join(args.output, os.path.splitext(os.path.basename(scene))[0]
                                 + "." + args.format)) for scene in args.scenes]
    if len({out for _, out in jobs}) != len(jobs):
        raise _usage("two inputs share a file name; their outputs would collide")
    _check_folder(os.path.abspath(args.output))
    _check_preset(args.preset)
    _check_colour(args)
    if any(scene.lower().endswith(".blend") for scene in args.scenes):
        from . import exporters  # noqa: F401  (Blender's pxr before the engine's)
    phases = _Phases(args.started)
    _import_render_path()
    phases.mark("imports")
    given = dict(view=args.view, look=args.look, exposure=args.exposure)
    failed = 0
    for scene, output in jobs:
        vars(args).update(given, scene=scene, output=output)
        try:
            if not os.path.isfile(scene):
                raise CommandError(f"{scene}: no such file")
            _render_frame(args, scene.lower().endswith(".blend"), phases)
        except CommandError as error:
            _fail(args, str(error))
            failed += 1
        except Exception as error:  # a bug on this file: one line, and the others go on
            if args.debug:
                raise
            _fail(args, f"{scene}: {_internal_error(error)}")
            failed += 1
        phases = _Phases(None)
    print(f"{len(jobs) - failed} rendered, {failed} failed")
    return FAILED if failed else 0


def _check_colour(args):
    """The view settings given on the command line, checked before any work; an unknown
    view or look is a usage error."""
    from .engine.color import ColorManagementError, check
    if args.view is None:
        return      # a --look alone belongs to the scene's view: checked with it
    try:
        check(args.view, args.look, args.exposure or 0.0)
    except ColorManagementError as error:
        raise _usage(str(error))


def _colour(stage, args):
    """The view settings for image writers: the command line's; else the stage's, as
    Blender's colour management was exported (a --look or --exposure alone applies over
    its view); else Standard. The stage's, when this OpenColorIO config lacks them, are
    a warning and Standard. Sets args.view, look and exposure to what applies."""
    from .engine.color import STANDARD, ColorManagementError, check
    from .engine.usd.camera import view_settings
    stored = view_settings(stage) if args.view is None else {}
    view = args.view or str(stored.get("view") or STANDARD)
    look = args.look if args.look is not None else (stored.get("look") or None)
    try:
        exposure = float(stored.get("exposure", 0.0)) if args.exposure is None else args.exposure
        check(view, look, exposure)
    except (ColorManagementError, ValueError, TypeError) as error:
        if args.look is not None:       # the command line's look, for the scene's view
            raise _usage(str(error))
        _print_warnings([f"{args.scene}: the scene's colour management cannot be applied "
                         f"({one_line(str(error))}); using {STANDARD}"], set())
        view, look, exposure = STANDARD, None, args.exposure or 0.0
    args.view, args.look, args.exposure = view, look, exposure
    return dict(view=view, look=look, exposure=exposure)


def _check_preset(name):
    from .core.presets import PRESETS
    if name not in PRESETS:
        raise _usage(f"unknown --preset {name!r}; valid presets: {', '.join(PRESETS)}")


def _open_usd(path):
    """A USD file opened with usd-core (no bpy)."""
    from .engine.usd.opening import UnreadableStage, composition_errors, open_stage
    try:
        stage = open_stage(path)
    except UnreadableStage as error:
        raise CommandError(str(error))
    # Missing or broken references, sublayers and payloads, and cycles: USD composes
    # what it can; say what it could not.
    _print_warnings([f"{path}: {reason}" for reason in composition_errors(stage)], set())
    interrupt.check()               # a Ctrl-C that USD swallowed while it read
    return stage


def _stage_from_blend(blend):
    """Export a .blend into an in-memory stage, in this process (with Blender's own pxr)."""
    from .exporters import ExportError, stage_from_blend
    try:
        stage, report = stage_from_blend(blend)
    except ExportError as error:
        raise CommandError(one_line(str(error)))
    _print_warnings(report.warnings, set())
    return stage


def _check_camera(stage, args):
    if args.camera is None:
        return
    from .engine.usd.camera import camera_path_problem
    problem = camera_path_problem(stage, args.camera, args.scene)
    if problem is not None:
        raise _usage(f"--camera {args.camera}: {problem}")


def _settings(args, frame=None):
    from .engine import RenderSettings
    width, height = args.size if args.size else (None, None)
    return RenderSettings(width=width, height=height, frame=frame, preset=args.preset,
                          camera=args.camera)


def _rendered(scene, run):
    """Runs a render; the engine's errors on this input become one line."""
    try:
        return run()
    except (ValueError, RuntimeError, OSError) as error:  # pxr's errors are RuntimeErrors
        raise CommandError(f"{scene}: {one_line(error_text(error))}")


def _write(path, write):
    interrupt.check()               # nothing is written after a Ctrl-C
    _make_folder(os.path.dirname(os.path.abspath(path)))
    try:
        write()
    except OSError as error:
        raise CommandError(f"{path}: cannot be written: {error.strerror or error}")


def _import_render_path():
    """What rendering one frame imports, at once, so that --timings can tell imports
    from work: USD, the engine with ModernGL, and the image writer (OpenImageIO). Not
    the colour management (OpenColorIO), which only a display view asks for."""
    from .engine import api, image_io  # noqa: F401
    from .engine.usd import opening  # noqa: F401  (USD)


def _render_frame(args, is_blend, phases):
    """args.scene, one frame, into args.output."""
    from .engine import render_stage
    from .engine.image_io import write_image
    stage = _stage_from_blend(args.scene) if is_blend else _open_usd(args.scene)
    _check_camera(stage, args)
    phases.mark("stage open")
    # An .exr is scene linear: the scene's view transform (OpenColorIO) is for displays.
    args.colour = {} if args.output.lower().endswith(".exr") else _colour(stage, args)
    from .cli_overlays import from_args as overlays_from_args
    args.overlays = overlays_from_args(args, stage, CommandError)
    phases.mark("encode and write")
    result = _rendered(args.scene, lambda: render_stage(stage, _settings(args, args.frame)))
    phases.mark("render")
    _print_warnings(result.warnings, set())
    overlay = None
    if args.overlays is not None:
        from .engine.usd.camera import default_time
        frame = args.frame if args.frame is not None else default_time(stage)
        overlay = functools.partial(args.overlays.apply, frame=frame)
    _write(args.output, lambda: write_image(args.output, result.rgba, **args.colour,
                                            overlay=overlay))
    phases.mark("encode and write")
    height_px, width_px = result.rgba.shape[:2]
    print(f"{args.scene} -> {args.output} ({width_px}x{height_px}, "
          f"{result.timings.get('total', 0.0) * 1000:.1f} ms)")
    if args.debug:
        print(_gl_line(result.stats))
    if args.timings:
        phases.report(args.scene, result)
    return 0


def _gl_line(stats) -> str:
    """--debug: the GL the engine got, and the paths it took."""
    return (f"  GL: {stats.get('gl_renderer')}, {stats.get('gl_version')} (asked for "
            f"{stats.get('gl_requested', 0) / 100:.1f}); paths: {stats.get('gl_path')}")


class _Phases:
    """--timings: the seconds of the phases of a render, as they pass."""

    def __init__(self, started):
        # started: (seconds from process start to main, or None; perf_counter at main)
        self.started = started
        self.seconds = {}
        self._last = time.perf_counter()

    def mark(self, name):
        now = time.perf_counter()
        self.seconds[name] = self.seconds.get(name, 0.0) + now - self._last
        self._last = now

    def report(self, scene, result):
        """Prints the phases, the render split by what the engine measured: its GL
        context and set-up, the scene read, the first frame (of which programs and
        uploads)."""
        t, s = result.timings, result.stats
        rows = []
        if self.started is not None:
            rows.append(("process start to main", self.started[0]))
        rows += [("imports", self.seconds.get("imports")),
                 ("stage open", self.seconds.get("stage open")),
                 ("GL context", t.get("context")), ("session setup", t.get("setup")),
                 ("scene read", t.get("load")),
                 ("programs", t.get("programs")), ("uploads", t.get("upload")),
                 ("first frame", t.get("total", 0.0) - t.get("load", 0.0)),
                 ("encode and write", self.seconds.get("encode and write"))]
        if self.started is not None and self.started[0] is not None:
            rows.append(("wall", self.started[0] + time.perf_counter() - self.started[1]))
        print(f"timings of {scene} (ms; programs and uploads are part of the first frame):")
        for name, seconds in rows:
            if seconds is not None:
                print(f"  {name:<24}{seconds * 1000:8.1f}")
        print(f"  programs: {s.get('programs_compiled', 0)} compiled, "
              f"{s.get('programs_loaded', 0)} loaded from the program cache")


def _seconds_since_start():
    """Wall seconds since this process started, from /proc (Linux, to 10 ms); None
    elsewhere."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def _render_sequence(stage, args, runner, stage_text):
    """--frames as tasks (farm/): chunks of frames on worker processes that keep the
    stage loaded, here or on a Dask cluster."""
    from .farm.batch import FarmError, render_frames
    from .farm.options import SequenceOptions
    if not args.output.lower().endswith(".gif"):
        _make_folder(os.path.dirname(os.path.abspath(args.output)))
    seen = set()
    try:
        options = SequenceOptions(
            scheduler=args.scheduler, jobs=args.jobs, collect=args.collect, resume=args.resume,
            status=_status_writer(args),
            scene=args.scene, output=args.output, frames=tuple(args.frames), size=args.size,
            preset=args.preset, camera=args.camera, chunk=args.chunk, **args.colour,
            overlays=args.overlays)
        status = render_frames(options, runner, stage_text, stage.GetFramesPerSecond() or 24.0,
                               lambda warnings: _print_warnings(warnings, seen))
    except FarmError as error:
        raise CommandError(str(error))
    except OSError as error:
        raise CommandError(f"{error.filename or args.output}: cannot be written: "
                           f"{error.strerror or error}")
    if status:
        raise CommandError(f"{args.scene}: some frames failed (see the summary above)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
