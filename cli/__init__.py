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

One module per sub-command (export.py, render.py; `lantern compare` is compare/
command.py), what they share in common.py. The entry point is `lantern.cli:main`.
"""
import argparse
import logging
import os
import sys
import time

from ..core import interrupt
from . import export, render
from .common import (EXIT_STATUSES, FAILED, INTERRUPTED, CommandError, VersionAction,
                     fail, internal_error, parse_size, usage)
from .timings import seconds_since_start


def _build_parser(argv=None):
    parser = argparse.ArgumentParser(
        prog="lantern", description=__doc__.splitlines()[0], epilog=EXIT_STATUSES,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action=VersionAction)
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

    parents = [common, farm]
    export.add_parser(commands, parents)
    render.add_parser(commands, parents)

    # `lantern compare` brings its package's imports: a render or export goes without.
    if _command(argv) not in ("render", "export"):
        from ..compare.command import add_parser as add_compare_parser
        add_compare_parser(commands, [common], parse_size, EXIT_STATUSES,
                           argparse.RawDescriptionHelpFormatter)
    return parser


def _command(argv):
    """The sub-command named on the command line (its first word that is no option)."""
    words = sys.argv[1:] if argv is None else argv
    return next((w for w in words if not w.startswith("-")), None)


def main(argv=None):
    started = (seconds_since_start(), time.perf_counter())
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
            from ..compare.command import run as compare
            return compare(args, usage, CommandError)
        return export.run(args) if args.command == "export" else render.run(args)
    except CommandError as error:
        fail(args, str(error))
        return error.status
    except KeyboardInterrupt:
        fail(args, "interrupted")
        return INTERRUPTED
    except Exception as error:  # a bug: one line, or the traceback with --debug
        if args.debug:
            raise
        fail(args, internal_error(error))
        return FAILED
