"""The compiler's helper process (compiler.py): a GL context of its own, like the
render process's, and a ProgramCache that stores what it makes in the persistent
program cache. Started by engine/host/boot.py with `compiler` for its handle."""
import sys

from ...core import cache_folder
from .compiler import receive, send
from .context import GLContext


def main() -> int:
    """Says its GL driver (nothing, and exit status 1, when it cannot store binaries),
    then makes each program it is handed and answers (key, None) or (key, why it
    failed)."""
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr            # nothing else may write to the channel
    gl = GLContext()
    if cache_folder.disabled() or not gl.loader.active:
        return 1
    info = gl.ctx.info
    send(out, (info["GL_VENDOR"], info["GL_RENDERER"], info["GL_VERSION"]))
    while True:
        job = receive(inp)
        if job is None:
            return 0
        key, args = job
        try:
            gl.programs.forget(gl.programs.get(*args))
            send(out, (key, None))
        except Exception as error:
            send(out, (key, f"{type(error).__name__}: {error}"))
