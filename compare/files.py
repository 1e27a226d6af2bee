"""Every file the report writes goes to a temporary name beside its target and is then
renamed: a reader never sees half a file, and an interrupted run leaves none.

(The same mechanism as core/files.py on the session branch; at merge this module can
become a thin user of core.files.atomic_write.)"""
from __future__ import annotations

import json
import os
import tempfile


def atomic_write(path: str, write, suffix: str = "") -> None:
    """Calls write(tmp_path) for a temporary file in `path`'s folder, then renames it
    to `path` with the permissions a plain open() would give; on any error the
    temporary file is removed and the error re-raised."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=suffix,
                               dir=folder)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_text(path: str, text: str) -> None:
    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
    atomic_write(path, write)


def write_json(path: str, data) -> None:
    write_text(path, json.dumps(data, indent=2, allow_nan=False) + "\n")
