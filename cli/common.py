"""What every sub-command of the command line shares: exit statuses and the error
that ends a command with one line, argument parsing, output and folder checks, and
warnings printed once."""
import argparse
import math
import os
import sys

from ..core import interrupt
from ..core.subdivision_modes import FILE_DEFAULT, SUBDIVISION_MODES
from ..core.text import error_text, one_line
from ..core.version import installed_version

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


def usage(message):
    return CommandError(message, USAGE)


def parse_size(text):
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size must look like 640x360, not {text!r}")
    if width <= 0 or height <= 0:
        raise argparse.ArgumentTypeError(f"--size must be positive, not {text!r}")
    if width > MAX_SIDE or height > MAX_SIDE:
        raise argparse.ArgumentTypeError(f"--size {text}: each side must be at most {MAX_SIDE}")
    return width, height


def number(text):
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(text)
    return value


def parse_frames(text):
    """'A:B' or 'A:B:STEP' -> the frames A, A+STEP, ... up to B (inclusive)."""
    parts = text.split(":")
    try:
        if len(parts) not in (2, 3):
            raise ValueError(text)
        first, last = number(parts[0]), number(parts[1])
        step = number(parts[2]) if len(parts) == 3 else 1.0
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames must look like 1:24 or 1:24:2, not {text!r}")
    if step <= 0:
        raise argparse.ArgumentTypeError(f"--frames {text}: the step must be positive")
    if last < first:
        raise argparse.ArgumentTypeError(f"--frames {text}: the last frame comes before the first")
    count = int(math.floor((last - first) / step + 1e-9)) + 1
    return [first + i * step for i in range(count)]


class VersionAction(argparse.Action):
    """--version, looked up only when asked for (importlib.metadata costs a plain
    render 20 ms)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="show the version and exit"):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"lantern {installed_version()}")     # on stdout, as argparse's own
        parser.exit()


def check_farm(args):
    if args.scheduler is not None and args.scheduler != "local" and "://" not in args.scheduler:
        raise usage(f"--scheduler {args.scheduler}: must be a Dask scheduler address like "
                     "tcp://HOST:8786, or 'local'")
    if args.jobs < 1:
        raise usage("-j must be at least 1")


def internal_error(error):
    return (f"internal error: {type(error).__name__}: {one_line(error_text(error))} "
            "(--debug shows the traceback)")


def fail(args, message):
    print(f"lantern {args.command}: {message}", file=sys.stderr, flush=True)


def check_output(path, kinds, what="output"):
    """Fails before any work when `path` cannot be written: wrong kind, a directory, or
    a folder that cannot be made or written."""
    if not path.lower().endswith(kinds):
        raise usage(f"{path}: the {what} must be {' or '.join(kinds)}")
    if os.path.isdir(path):
        raise usage(f"{path}: is a directory, not a file name")
    check_folder(os.path.dirname(os.path.abspath(path)))


def check_folder(folder):
    """The folder, or its nearest existing ancestor (missing folders are made), must be a
    writable directory."""
    existing = folder
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        raise CommandError(f"{folder}: cannot be made: {existing} is not a directory")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise CommandError(f"{folder}: {existing} is not writable")


def make_folder(folder):
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise CommandError(f"{folder}: cannot be made: {error.strerror}")


def print_warnings(warnings, seen):
    for warning in warnings:
        if warning not in seen:
            seen.add(warning)
            print(f"warning: {warning}", file=sys.stderr)


def status_writer(args):
    """--status-fd: a function writing one state per line to that descriptor."""
    if args.status_fd is None:
        return None

    def write(state):
        try:
            os.write(args.status_fd, f"{state}\n".encode())
        except OSError:          # the reader went away: the work goes on
            pass
    return write


def add_subdivision_option(parser, scope=""):
    """--subdivision: what `lantern export` writes, and what `lantern render` renders of
    a .blend (the same)."""
    parser.add_argument(
        "--subdivision", choices=tuple(SUBDIVISION_MODES), default=FILE_DEFAULT,
        help=f"for a mesh{scope} whose last modifier is a Catmull-Clark Subdivision "
             "Surface, write " + "; ".join(f"{name}: {text}"
                                          for name, text in SUBDIVISION_MODES.items())
             + f" (default {FILE_DEFAULT})")


def check_preset(name):
    from ..core.presets import PRESETS
    if name not in PRESETS:
        raise usage(f"unknown --preset {name!r}; valid presets: {', '.join(PRESETS)}")


def write_output(path, write):
    interrupt.check()               # nothing is written after a Ctrl-C
    make_folder(os.path.dirname(os.path.abspath(path)))
    try:
        write()
    except OSError as error:
        raise CommandError(f"{path}: cannot be written: {error.strerror or error}")
