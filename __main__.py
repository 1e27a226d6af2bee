"""`python -m lantern`: the command line. Ctrl-C is answered before anything heavy is
imported (core/interrupt.py)."""
from .core.interrupt import exit_at_once

exit_at_once()

from .cli import main  # noqa: E402  (after the handler, on purpose)

raise SystemExit(main())
