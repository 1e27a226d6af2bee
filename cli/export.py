"""`lantern export`: one .blend to a USD file in this process, or many into a folder as
a batch (farm/), each in its own Blender process, going on past a bad file."""
import argparse
import os

from ..core.text import one_line
from .common import (EXIT_STATUSES, USD_SUFFIXES, CommandError, add_subdivision_option,
                     check_farm, check_folder, check_output, make_folder, print_warnings,
                     status_writer, usage)


def add_parser(commands, parents):
    export = commands.add_parser("export", parents=parents, help="export .blend files to USD",
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
    add_subdivision_option(export)


def run(args):
    for blend in args.blends:
        if not blend.lower().endswith(".blend"):
            raise usage(f"{blend}: not a .blend file")
    if args.max_influences is not None and args.max_influences < 1:
        raise usage("--max-influences must be at least 1")
    check_farm(args)
    single = args.output.lower().endswith(USD_SUFFIXES)
    if args.collect and args.textures == "reference":
        raise usage("--collect needs --textures copy: referenced images would be named "
                     "relative to the worker's folder, not the output's")
    if single and len(args.blends) > 1:
        raise usage(f"{args.output}: several inputs need a folder for -o")
    if not single and os.path.splitext(args.output)[1] and not os.path.isdir(args.output):
        raise usage(f"{args.output}: -o must be a .usd, .usda or .usdc file, or a folder")
    if single and (args.scheduler is not None or args.collect or args.resume):
        raise usage("--scheduler, --collect and --resume are for a batch: give -o a folder")
    if single:
        check_output(args.output, USD_SUFFIXES)
        return _export_one(args.blends[0], args.output, args)
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        raise usage(f"{args.output}: is a file, not a folder")
    check_folder(os.path.abspath(args.output))
    return _export_batch(args)


def _export_one(blend, out_path, args):
    """Export in this process. Prints warnings; returns the exit status."""
    if not os.path.isfile(blend):
        raise CommandError(f"{blend}: no such file")
    from ..exporters import ExportError, ExportOptions, export_blend
    options = ExportOptions(textures=args.textures, max_influences=args.max_influences,
                            subdivision=args.subdivision)
    try:
        report = export_blend(blend, out_path, options)
    except ExportError as error:
        raise CommandError(one_line(str(error)))
    except OSError as error:
        raise CommandError(f"{out_path}: cannot be written: {error.strerror or error}")
    print_warnings(report.warnings, set())
    counts = ", ".join(f"{n} {kind}" for kind, n in report.counts.items() if n)
    print(f"{blend} -> {report.path} ({counts}; {report.seconds:.2f} s)")
    return 0


def _export_batch(args):
    from ..farm.batch import FarmError, export_batch
    from ..farm.options import ExportBatchOptions
    jobs = []
    for blend in args.blends:
        stem = os.path.splitext(os.path.basename(blend))[0]
        jobs.append((blend, os.path.join(args.output, f"{stem}.{args.format}")))
    if len({out for _, out in jobs}) != len(jobs):
        raise usage("two inputs share a file name; their outputs would collide")
    make_folder(args.output)
    try:
        return export_batch(ExportBatchOptions(
            scheduler=args.scheduler, jobs=args.jobs, collect=args.collect, resume=args.resume,
            status=status_writer(args), textures=args.textures,
            max_influences=args.max_influences, subdivision=args.subdivision), jobs)
    except FarmError as error:
        raise CommandError(str(error))
