"""Writes that never leave a half-written file: a temporary name beside the target,
then a rename (atomic on one file system). Used for every file Lantern writes:
exported USD layers and rendered images."""
from __future__ import annotations

import os
import tempfile


def atomic_write(path: str, write, suffix: str = "", keep_mode: bool = False) -> None:
    """Calls write(tmp_path) for a temporary file in `path`'s folder (which must
    exist), then renames it to `path`; on any error the temporary file is removed and
    the error re-raised.
    keep_mode: give the file the permissions a plain open() would (mkstemp makes it
    0600), for files other users read."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=suffix,
                               dir=folder)
    os.close(fd)
    try:
        write(tmp)
        if keep_mode:
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
