"""Ctrl-C, answered the same whenever it comes: one line and exit status 130.

Before the command line has anything to clean up, it exits at once, whatever is being
imported (`exit_at_once`, installed first thing by `python -m lantern` and by the CLI's
`main`). Once work starts, SIGINT raises KeyboardInterrupt, which each command answers
by closing its workers and removing what it half wrote (`raise_keyboard_interrupt`).
Two things could lose it then, and both are covered: USD's C++ swallows a Python
exception raised inside its module imports (a warning and a traceback, "Error loading
lib gf's module"), so a Ctrl-C during an import is only recorded, and `check()` raises
it where the commands look (after a stage is read, before a file is written, in the
wait on workers); and a signal that lands on another thread (USD's TBB workers, rich's
refresh thread) does not interrupt the main thread's wait on its workers, so the wait
also watches `wakeup_fd()`, which the signal writes to."""
from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

INTERRUPTED = 130
COMMANDS = ("export", "render", "compare")


def _exit_now(signum, frame):
    command = next((a for a in sys.argv[1:] if a in COMMANDS), None)
    os.write(2, f"lantern{' ' + command if command else ''}: interrupted\n".encode())
    os._exit(INTERRUPTED)


def exit_at_once():
    """Ctrl-C exits at once (nothing written yet); returns the handler it replaced, or
    None off the main thread (where signals cannot be handled)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGINT, _exit_now)


_requested = False
_deferring = 0               # > 0 inside deferred(): a Ctrl-C is recorded, raised after
_wakeup = None               # (read end, write end) of the signal's wake-up pipe


def _raise(signum, frame):
    global _requested
    _requested = True
    # Inside an import USD would swallow it (with a warning), and inside a worker's
    # start it would leave a child reading half its start-up data: check() raises it
    # when they are done.
    if not _deferring and not _importing(frame):
        raise KeyboardInterrupt


@contextlib.contextmanager
def deferred():
    """A block that a Ctrl-C does not cut in two: it is raised when the block ends."""
    global _deferring
    _deferring += 1
    try:
        yield
    finally:
        _deferring -= 1
    if not _deferring:
        check()


def _importing(frame) -> bool:
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def raise_keyboard_interrupt():
    """Ctrl-C raises KeyboardInterrupt, for work that cleans up after itself."""
    global _wakeup
    if threading.current_thread() is not threading.main_thread():
        return
    if _wakeup is None:
        read, write = os.pipe()
        os.set_blocking(read, False)
        os.set_blocking(write, False)
        _wakeup = (read, write)
    signal.set_wakeup_fd(_wakeup[1], warn_on_full_buffer=False)
    signal.signal(signal.SIGINT, _raise)


def check():
    """Raises KeyboardInterrupt if Ctrl-C came and something swallowed it."""
    if _requested:
        raise KeyboardInterrupt


def wakeup_fd():
    """A file descriptor that becomes readable when a signal arrives (None before
    raise_keyboard_interrupt), for waits to watch besides what they wait for."""
    return None if _wakeup is None else _wakeup[0]


def drain():
    """Empties the wake-up pipe, then raises KeyboardInterrupt if Ctrl-C came."""
    if _wakeup is not None:
        try:
            while os.read(_wakeup[0], 512):
                pass
        except (BlockingIOError, OSError):
            pass
    check()


def restore(previous):
    """The handler exit_at_once replaced, back (a CLI run inside another program)."""
    global _requested
    if previous is not None and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, previous)
        signal.set_wakeup_fd(-1)
        _requested = False
