"""`python -m lantern`: the command line."""
from .cli import main

raise SystemExit(main())
