"""`python -m lantern`: the command line. Ctrl-C is answered before anything heavy is
imported (core/interrupt.py)."""
import gc

from .core.interrupt import exit_at_once

exit_at_once()

from .cli import main  # noqa: E402  (after the handler, on purpose)

status = main()
# What the command made lives until the process ends: the collections Python runs while
# it shuts down need not trace it (after a render, USD's, NumPy's and ModernGL's objects:
# most of 0.1-0.2 s of a cold `lantern render`'s exit).
gc.freeze()
raise SystemExit(status)
