"""`lantern render`: one frame of a USD file or .blend into an image, several scenes
into a folder with one GL context, or a sequence (--frames) as chunks on worker
processes that keep the stage loaded (farm/), here or on a Dask cluster."""
import argparse
import functools
import os

from ..core import interrupt
from ..core.text import error_text, one_line
from .common import (EXIT_STATUSES, FAILED, IMAGE_SUFFIXES, MAX_SIDE, RENDER_PROCESSES,
                     USD_SUFFIXES, CommandError, add_subdivision_option, check_farm,
                     check_folder, check_output, check_preset, fail, internal_error,
                     make_folder, number, parse_frames, parse_size, print_warnings,
                     status_writer, usage, write_output)
from .gpu import add_option as add_gpu_option
from .gpu import check_gpu, gl_line
from .products import add_options as add_product_options
from .products import check as check_product
from .products import frame_pattern, parse_passes, plan
from .timings import Phases


def add_parser(commands, parents):
    render = commands.add_parser("render", parents=parents,
                                 help="render a USD stage or a .blend file",
                                 epilog=EXIT_STATUSES,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    render.add_argument("scenes", nargs="+", metavar="scene.usd|scene.blend")
    render.add_argument("-o", "--output", default=None,
                        help="an .exr (scene linear) or .png (sRGB); for --frames, a name "
                             "with '####' or $F4 (the frame) or a .gif; for several scenes, "
                             "a folder (outputs named after the inputs; for one, end it "
                             "with /). The one output, the plain image (or --passes'): the stage's "
                             "RenderProducts are rendered only without -o")
    render.add_argument("--format", choices=("png", "exr"), default="png",
                        help="image format of the outputs written into a folder (default png)")
    render.add_argument("--timings", action="store_true",
                        help="print the phases of the render: process start to main, "
                             "imports, GL context, stage open, scene read, programs, "
                             "uploads, first frame, encode and write")
    render.add_argument("--frame", type=number, default=None, help="time code / frame to render")
    render.add_argument("--frames", type=parse_frames, default=None, metavar="A:B[:STEP]",
                        help="render frames A..B every STEP (default 1); '####' in -o becomes "
                             "the zero-padded frame, an -o ending in .gif writes one preview")
    render.add_argument("--size", type=parse_size, default=None, metavar="WxH",
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
                             f"(default {RENDER_PROCESSES}); worker k draws on GPU k mod "
                             "the number of GPUs")
    add_gpu_option(render)
    add_subdivision_option(render, " of a .blend input")
    from .overlays import add_options as add_overlay_options
    add_overlay_options(render)
    add_product_options(render)


def run(args):
    args.passes = parse_passes(args.passes)
    if args.output is not None:
        args.output = frame_pattern(args.output)
    elif len(args.scenes) > 1:
        raise usage("several scenes need a folder for -o")
    if len(args.scenes) > 1 or _is_folder(args.output or ""):
        return _render_files(args)
    args.scene = args.scenes[0]
    if args.frames is not None and args.frame is not None:
        raise usage("--frame and --frames cannot be used together")
    if args.passes and (args.output is None or not args.output.lower().endswith(".exr")):
        raise usage(f"--passes: render passes need an .exr for -o, not {args.output}")
    if args.output is None:
        pass                            # the stage's RenderProducts: checked once read
    elif args.frames is None:
        check_output(args.output, IMAGE_SUFFIXES)
    elif args.output.lower().endswith(".gif"):
        check_output(args.output, (".gif",))
    else:
        check_output(args.output, IMAGE_SUFFIXES)
        if "#" not in args.output:
            raise usage(f"{args.output}: a sequence needs '####' in an .exr/.png name, or a .gif")
    _check_render_options(args)
    if not os.path.isfile(args.scene):
        raise CommandError(f"{args.scene}: no such file")
    is_blend = args.scene.lower().endswith(".blend")
    if not is_blend and not args.scene.lower().endswith(USD_SUFFIXES):
        raise usage(f"{args.scene}: expected a .usd, .usda, .usdc or .blend file")
    if is_blend:
        from .. import exporters  # noqa: F401  (Blender's pxr before the engine's)
    check_preset(args.preset)
    _check_colour(args)

    if args.frames is None:
        phases = Phases(args.started)
        _import_render_path()
        phases.mark("imports")
        return _render_frame(args, is_blend, phases)
    # A sequence's workers start first, and get ready while the stage is read here.
    from ..farm.batch import FarmError, open_render_runner
    try:
        runner = open_render_runner(args.scheduler, args.jobs)
    except FarmError as error:
        raise CommandError(str(error))
    try:
        stage = _stage_from_blend(args.scene, args.subdivision) if is_blend else _open_usd(args.scene)
        _check_camera(stage, args)
        args.sequence_outputs = _outputs(args, stage, sequence=True)
        args.colour = _colour(stage, args)
        from .overlays import from_args as overlays_from_args
        args.overlays = overlays_from_args(args, stage, CommandError)
        # A .blend's stage was exported here: the workers get it as text.
        text = stage.GetRootLayer().ExportToString() if is_blend else None
    except BaseException:
        runner.close(interrupted=True)
        raise
    return _render_sequence(stage, args, runner, text)


def _check_render_options(args):
    check_farm(args)
    check_gpu(args)
    if args.timings and args.frames is not None:
        raise usage("--timings is for single frames, not --frames")
    if args.frames is None and (args.scheduler is not None or args.collect or args.resume
                                or args.chunk is not None):
        raise usage("--scheduler, --collect, --resume and --chunk are for a sequence "
                     "(--frames)")
    if args.chunk is not None and args.chunk < 1:
        raise usage("--chunk must be at least 1")
    if args.camera is not None and not args.camera.startswith("/"):
        raise usage(f"--camera {args.camera}: must be an absolute prim path, like /root/Camera")
    from .overlays import check as check_overlays
    check_overlays(args, usage, CommandError)


def _is_folder(output):
    """-o names a folder for one scene when it ends with a separator (an image name that
    is a directory stays a usage error); several scenes always take a folder."""
    return output.endswith(("/", os.sep))


def _render_files(args):
    """Several scenes, one image each, into the folder -o, in this process: one GL
    context and one program cache for all. A file that cannot be read or rendered is
    one line, and the others go on; the exit status is then 1."""
    if args.frames is not None:
        raise usage("--frames renders one scene: give several scenes one frame each")
    _check_render_options(args)
    for scene in args.scenes:
        if not scene.lower().endswith(USD_SUFFIXES + (".blend",)):
            raise usage(f"{scene}: expected a .usd, .usda, .usdc or .blend file")
    if args.output.lower().endswith(IMAGE_SUFFIXES + (".gif",)):
        raise usage(f"{args.output}: several scenes need a folder for -o")
    if args.passes and args.format != "exr":
        raise usage("--passes: render passes need --format exr")
    args.products = False           # the folder names the outputs, not the stages
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        raise usage(f"{args.output}: is a file, not a folder")
    jobs = [(scene, os.path.join(args.output, os.path.splitext(os.path.basename(scene))[0]
                                 + "." + args.format)) for scene in args.scenes]
    if len({out for _, out in jobs}) != len(jobs):
        raise usage("two inputs share a file name; their outputs would collide")
    check_folder(os.path.abspath(args.output))
    check_preset(args.preset)
    _check_colour(args)
    if any(scene.lower().endswith(".blend") for scene in args.scenes):
        from .. import exporters  # noqa: F401  (Blender's pxr before the engine's)
    phases = Phases(args.started)
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
        except DeviceUnusable:
            raise
        except CommandError as error:
            fail(args, str(error))
            failed += 1
        except Exception as error:  # a bug on this file: one line, and the others go on
            if args.debug:
                raise
            fail(args, f"{scene}: {internal_error(error)}")
            failed += 1
        phases = Phases(None)
    print(f"{len(jobs) - failed} rendered, {failed} failed")
    return FAILED if failed else 0


def _check_colour(args):
    """The view settings given on the command line, checked before any work; an unknown
    view or look is a usage error."""
    from ..engine.color import ColorManagementError, check
    if args.view is None:
        return      # a --look alone belongs to the scene's view: checked with it
    try:
        check(args.view, args.look, args.exposure or 0.0)
    except ColorManagementError as error:
        raise usage(str(error))


def _colour(stage, args):
    """The view settings for image writers: the command line's; else the stage's, as
    Blender's colour management was exported (a --look or --exposure alone applies over
    its view); else Standard. The stage's, when this OpenColorIO config lacks them, are
    a warning and Standard. Sets args.view, look and exposure to what applies."""
    from ..engine.color import STANDARD, ColorManagementError, check
    from ..engine.usd.camera import view_settings
    stored = view_settings(stage) if args.view is None else {}
    view = args.view or str(stored.get("view") or STANDARD)
    look = args.look if args.look is not None else (stored.get("look") or None)
    try:
        exposure = float(stored.get("exposure", 0.0)) if args.exposure is None else args.exposure
        check(view, look, exposure)
    except (ColorManagementError, ValueError, TypeError) as error:
        if args.look is not None:       # the command line's look, for the scene's view
            raise usage(str(error))
        print_warnings([f"{args.scene}: the scene's colour management cannot be applied "
                         f"({one_line(str(error))}); using {STANDARD}"], set())
        view, look, exposure = STANDARD, None, args.exposure or 0.0
    args.view, args.look, args.exposure = view, look, exposure
    return dict(view=view, look=look, exposure=exposure)


def _open_usd(path):
    """A USD file opened with usd-core (no bpy)."""
    from ..engine.usd.opening import UnreadableStage, composition_errors, open_stage
    try:
        stage = open_stage(path)
    except UnreadableStage as error:
        raise CommandError(str(error))
    # Missing or broken references, sublayers and payloads, and cycles: USD composes
    # what it can; say what it could not.
    print_warnings([f"{path}: {reason}" for reason in composition_errors(stage)], set())
    interrupt.check()               # a Ctrl-C that USD swallowed while it read
    return stage


def _stage_from_blend(blend, subdivision):
    """Export a .blend into an in-memory stage, in this process (with Blender's own pxr),
    as `lantern export` would write it."""
    from ..exporters import ExportError, ExportOptions, stage_from_blend
    try:
        stage, report = stage_from_blend(blend, ExportOptions(subdivision=subdivision))
    except ExportError as error:
        raise CommandError(one_line(str(error)))
    print_warnings(report.warnings, set())
    return stage


def _check_camera(stage, args):
    if args.camera is None:
        return
    from ..engine.usd.camera import camera_path_problem
    problem = camera_path_problem(stage, args.camera, args.scene)
    if problem is not None:
        raise usage(f"--camera {args.camera}: {problem}")


def _settings(args, frame=None):
    from ..engine import RenderSettings
    width, height = args.size if args.size else (None, None)
    return RenderSettings(width=width, height=height, frame=frame, preset=args.preset,
                          camera=args.camera)


class DeviceUnusable(CommandError):
    """The GL device cannot be drawn on (engine/gpu/devices.py): no file can render."""


def _rendered(scene, run):
    """Runs a render; the engine's errors on this input become one line."""
    try:
        return run()
    except (ValueError, RuntimeError, OSError) as error:  # pxr's errors are RuntimeErrors
        from ..engine.gpu.devices import DeviceError
        if isinstance(error, DeviceError):
            raise DeviceUnusable(one_line(str(error)))
        raise CommandError(f"{scene}: {one_line(error_text(error))}")


def _import_render_path():
    """What rendering one frame imports, at once, so that --timings can tell imports
    from work: USD, the engine with ModernGL, and the image writer (OpenImageIO). Not
    the colour management (OpenColorIO), which only a display view asks for."""
    from ..engine import api, image_io  # noqa: F401
    from ..engine.usd import opening  # noqa: F401  (USD)


def _render_frame(args, is_blend, phases):
    """args.scene, one frame, into each of its outputs (cli/products.py)."""
    from ..engine import Session
    from ..engine.usd.camera import default_time
    from ..core.text import frame_path
    from .products import write
    stage = _stage_from_blend(args.scene, args.subdivision) if is_blend else _open_usd(args.scene)
    _check_camera(stage, args)
    outputs = _outputs(args, stage, sequence=False)
    phases.mark("stage open")
    # An .exr is scene linear: the scene's view transform (OpenColorIO) is for displays.
    pngs = any(not o.output.lower().endswith(".exr") for o in outputs)
    colour = _colour(stage, args) if pngs else {}
    from .overlays import from_args as overlays_from_args
    args.overlays = overlays_from_args(args, stage, CommandError)
    phases.mark("encode and write")
    frame = args.frame if args.frame is not None else default_time(stage)
    overlay = None
    if args.overlays is not None:
        overlay = functools.partial(args.overlays.apply, frame=frame)
    first, seen = None, set()
    session = _rendered(args.scene, lambda: Session(stage, _settings(args, args.frame)))
    try:
        for output in outputs:
            width, height = output.size or (None, None)
            session.configure(width=width, height=height, camera=output.camera,
                              passes=frozenset(output.passes))
            result = _rendered(args.scene, session.render)
            phases.mark("render")
            print_warnings(result.warnings, seen)
            path = frame_path(output.output, 1.0 if frame is None else frame)
            write_output(path, lambda: write(
                output, path, result, {} if path.lower().endswith(".exr") else colour,
                overlay))
            phases.mark("encode and write")
            height_px, width_px = result.rgba.shape[:2]
            count = len(result.passes)
            holds = f"{count} pass{'es' * (count != 1)}" if count else \
                "Combined layer" if output.layered else "plain RGBA"
            print(f"{args.scene} -> {path} ({output.origin}: {width_px}x{height_px}, "
                  f"{holds}, {result.timings.get('total', 0.0) * 1000:.1f} ms)")
            first = first or result
    finally:
        session.close()
    if args.debug:
        print(gl_line(first.stats))
    if args.timings:
        phases.report(args.scene, first)
    return 0


def _outputs(args, stage, sequence):
    """The render's outputs (cli/products.py), each checked before any render."""
    seen = set()
    outputs = plan(args, stage, lambda warnings: print_warnings(warnings, seen)) \
        if getattr(args, "products", True) else [_plain_output(args)]
    kinds = IMAGE_SUFFIXES + ((".gif",) if sequence and len(outputs) == 1 else ())
    if len(outputs) > 1 and outputs[0].output.lower().endswith(".gif"):
        raise usage(f"{outputs[0].output}: a .gif is the only output; the stage names "
                    f"{len(outputs)} RenderProducts (use --settings, or an image name)")
    for i, output in enumerate(outputs):
        check_product(output, sequence, i == 0 and args.output is not None, kinds)
    return outputs


def _plain_output(args):
    from ..farm.options import Product
    return Product(args.output, args.size, args.camera, args.passes or ())


def _render_sequence(stage, args, runner, stage_text):
    """--frames as tasks (farm/): chunks of frames on worker processes that keep the
    stage loaded, here or on a Dask cluster."""
    from ..farm.batch import FarmError, render_frames
    from ..farm.options import SequenceOptions
    outputs = args.sequence_outputs
    for output in outputs:
        if not output.output.lower().endswith(".gif"):
            make_folder(os.path.dirname(os.path.abspath(output.output)))
    seen = set()
    try:
        options = SequenceOptions(
            scheduler=args.scheduler, jobs=args.jobs, collect=args.collect, resume=args.resume,
            status=status_writer(args),
            scene=args.scene, products=tuple(outputs), frames=tuple(args.frames),
            preset=args.preset, chunk=args.chunk, **args.colour,
            overlays=args.overlays)
        status = render_frames(options, runner, stage_text, stage.GetFramesPerSecond() or 24.0,
                               lambda warnings: print_warnings(warnings, seen))
    except FarmError as error:
        raise CommandError(str(error))
    except OSError as error:
        raise CommandError(f"{error.filename or outputs[0].output}: cannot be written: "
                           f"{error.strerror or error}")
    if status:
        raise CommandError(f"{args.scene}: some frames failed (see the summary above)")
    return 0
