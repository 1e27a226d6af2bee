"""The `lantern compare` sub-command: its options, checked before any work, and the
exit status (0 done; 1 the scene could not be read or a render failed, the report
then lists it; 2 a wrong command line)."""
from __future__ import annotations

import argparse
import os

from .modes import MODES
from .run import Options, preset_names

DEFAULTS = Options(scene="", out="")   # one table of defaults: run.Options


def _csv(values):
    return ",".join(map(str, values))


def _samples(text):
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected sample counts like 1,4,16, not {text!r}")
    if not values or any(v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"sample counts must be positive integers: {text!r}")
    return tuple(sorted(set(values)))


def _names(text):
    values = tuple(dict.fromkeys(part.strip() for part in text.split(",") if part.strip()))
    if not values:
        raise argparse.ArgumentTypeError(f"expected comma-separated names, not {text!r}")
    return values


def _modes(text):
    values = _names(text)
    wrong = [v for v in values if v not in MODES]
    if wrong:
        raise argparse.ArgumentTypeError(f"{', '.join(wrong)}: choose from {', '.join(MODES)}")
    return values


def add_parser(commands, parents, parse_size, epilog, formatter):
    compare = commands.add_parser(
        "compare", parents=parents, epilog=epilog, formatter_class=formatter,
        help="time Lantern against Cycles and EEVEE, with error, as an HTML report")
    compare.add_argument("scene", metavar="scene.blend")
    compare.add_argument("-o", "--output", required=True, metavar="DIR",
                         help="the report folder (index.html, results.json, images)")
    compare.add_argument("--frame", type=float, default=None,
                         help="frame to render (default: the scene's current frame)")
    compare.add_argument("--size", type=parse_size, default=None, metavar="WxH",
                         help="image size (default: 320 wide, the scene's aspect)")
    compare.add_argument("--presets", type=_names, default=None,
                         help="Lantern presets, comma-separated (default: all of them, "
                              "low,medium,high,ultra)")
    compare.add_argument("--cycles-samples", type=_samples, default=DEFAULTS.cycles_samples,
                         metavar="N,N,...",
                         help=f"the Cycles sweep (default {_csv(DEFAULTS.cycles_samples)})")
    compare.add_argument("--reference-samples", type=int, default=DEFAULTS.reference_samples,
                         metavar="N", help="samples of the cached Cycles reference "
                                           f"(default {DEFAULTS.reference_samples})")
    compare.add_argument("--eevee", action="store_true", help="also render EEVEE")
    compare.add_argument("--eevee-samples", type=_samples, default=DEFAULTS.eevee_samples,
                         metavar="N,N,...", help="EEVEE's samples with --eevee "
                                                 f"(default {_csv(DEFAULTS.eevee_samples)})")
    compare.add_argument("--cycles-denoised", action="store_true",
                         help="also sweep Cycles with its denoiser (OpenImageDenoise), as its own curve")
    compare.add_argument("--mode", type=_modes, default=DEFAULTS.modes,
                         help="full (the scene's bounces, the default), direct (Cycles max "
                              "bounces 0, Lantern bounces 0), or direct,full: one "
                              "reference, Lantern image and section each")
    compare.add_argument("--jobs", "-j", type=int, default=DEFAULTS.jobs, metavar="N",
                         help="renders at once (default 1: above 1, times share the cores)")
    compare.add_argument("--pixel-filter", type=float, default=DEFAULTS.pixel_filter,
                         metavar="PX",
                         help=f"Cycles' Blackman-Harris filter width (default "
                              f"{DEFAULTS.pixel_filter:g}, Cycles' own; "
                              "0.01 point-samples pixel centres, as Lantern shades them)")
    compare.add_argument("--warm-runs", type=int, default=DEFAULTS.warm_runs, metavar="N",
                         help="Lantern renders whose median is the warm time "
                              f"(default {DEFAULTS.warm_runs})")
    compare.add_argument("--cache", default=None, metavar="DIR",
                         help="reference cache (default $LANTERN_COMPARE_CACHE or "
                              "~/.cache/lantern/compare)")
    return compare


def options_from(args, usage_error):
    """Options for run.compare from parsed arguments; usage_error(message) for the
    wrong ones that argparse cannot see."""
    from .run import Options
    presets = preset_names()
    wrong = [p for p in args.presets or () if p not in presets]
    if wrong:
        raise usage_error(f"--presets {', '.join(wrong)}: valid presets: {', '.join(presets)}")
    if not args.scene.lower().endswith(".blend"):
        raise usage_error(f"{args.scene}: compare needs a .blend file")
    if args.reference_samples < 1:
        raise usage_error("--reference-samples must be at least 1")
    if args.jobs < 1:
        raise usage_error("--jobs must be at least 1")
    if args.warm_runs < 1:
        raise usage_error("--warm-runs must be at least 1")
    if not args.pixel_filter > 0:
        raise usage_error("--pixel-filter must be positive")
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        raise usage_error(f"{args.output}: is a file, not a folder")
    return Options(scene=args.scene, out=args.output, frame=args.frame, size=args.size,
                   presets=args.presets or presets, cycles_samples=args.cycles_samples,
                   reference_samples=args.reference_samples, eevee=args.eevee,
                   eevee_samples=args.eevee_samples, modes=args.mode,
                   cycles_denoised=args.cycles_denoised, jobs=args.jobs, cache=args.cache,
                   pixel_filter=args.pixel_filter, warm_runs=args.warm_runs)


def run(args, usage_error, failed_error) -> int:
    """Runs the comparison: the summary line on stdout; returns the exit status."""
    import sys

    from .run import CompareError, compare
    options = options_from(args, usage_error)
    if not os.path.isfile(options.scene):
        raise failed_error(f"{options.scene}: no such file")
    try:
        results = compare(options)
    except CompareError as error:
        raise failed_error(str(error))
    print(results["summary"])
    for failure in results["failures"]:
        print(f"warning: {failure['job']} failed: {failure['error']}", file=sys.stderr)
    print(f"report: {os.path.join(options.out, 'index.html')}", file=sys.stderr)
    return 1 if results["failures"] else 0
