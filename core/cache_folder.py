"""Lantern's cache folder on the user's machine: what a process made that the next one
can load instead of making again. It holds the GL program binaries
(engine/gpu/program_binaries.py) and the display transforms resolved from OpenColorIO's
config (engine/color_cache.py), each file named by the sha256 of all that made it.

LANTERN_PROGRAM_CACHE_DIR moves it (the tests keep theirs in a temporary folder, and
Blender's side, addon/host.py, gives the engine process the extension's own user
folder, which Blender removes with the extension); LANTERN_NO_PROGRAM_CACHE=1 turns it
off. A folder that cannot be written costs the speed-up, never a render."""
from __future__ import annotations

import os
import sys


def disabled() -> bool:
    return os.environ.get("LANTERN_NO_PROGRAM_CACHE", "").strip() not in ("", "0")


def cache_folder() -> str:
    """LANTERN_PROGRAM_CACHE_DIR, else the user's cache folder for Lantern's programs
    (XDG_CACHE_HOME or ~/.cache on Linux, ~/Library/Caches on macOS, LOCALAPPDATA on
    Windows)."""
    explicit = os.environ.get("LANTERN_PROGRAM_CACHE_DIR")
    if explicit:
        return explicit
    home = os.path.expanduser("~")
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or os.path.join(home, "AppData", "Local")
        return os.path.join(base, "lantern", "Cache", "programs")
    if sys.platform == "darwin":
        return os.path.join(home, "Library", "Caches", "lantern", "programs")
    return os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.join(home, ".cache"),
                        "lantern", "programs")
