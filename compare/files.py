"""Every file the report writes goes to a temporary name beside its target and is then
renamed (core.files.atomic_write): a reader never sees half a file, and an interrupted
run leaves none. Worker logs (DIR/logs/*.log) are the one exception: they are streams."""
from __future__ import annotations

import json
import os

from ..core.files import atomic_write as _atomic_write


def atomic_write(path: str, write, suffix: str = "") -> None:
    """core.files.atomic_write, making the folder first; files get the permissions a
    plain open() would, since others read the report."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    _atomic_write(path, write, suffix=suffix)


def write_text(path: str, text: str) -> None:
    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
    atomic_write(path, write)


def write_json(path: str, data) -> None:
    write_text(path, json.dumps(data, indent=2, allow_nan=False) + "\n")
