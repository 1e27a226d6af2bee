"""Writes that never leave a half-written file: a temporary name beside the target,
then a rename (atomic on one file system). Used for every file Lantern writes:
exported USD layers and rendered images."""
from __future__ import annotations

import os
import tempfile


def atomic_write(path: str, write, suffix: str = "") -> None:
    """Calls write(tmp_path) for a temporary file in `path`'s folder (which must
    exist), then renames it to `path`; on any error the temporary file is removed and
    the error re-raised. The file gets the permissions a plain open() would give it
    (0666 less the umask): mkstemp makes it 0600, which would keep a render farm's
    outputs on shared storage from everyone else."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=suffix,
                               dir=folder)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def atomic_write_bytes(path: str, data: bytes, suffix: str = "") -> None:
    """atomic_write of bytes already in memory."""
    atomic_write(path, lambda tmp: _write_bytes(tmp, data), suffix=suffix)


def write_bytes(path: str, data: bytes) -> None:
    """Bytes into a file, not atomically (for a file atomic_write is making)."""
    _write_bytes(path, data)


def _write_bytes(path, data):
    with open(path, "wb") as f:
        f.write(data)


def current_umask() -> int:
    """The process's umask (reading it means setting it: set it straight back)."""
    umask = os.umask(0o022)
    os.umask(umask)
    return umask
