"""The two tasks, and what a worker does with each.

Exporting one .blend file and rendering a chunk of frames are the only tasks. Both are
plain frozen dataclasses, pickled to a worker by reference to this module (workers run
the same Lantern), and both come back as a TaskResult. A task never raises for a bad
input or a failed write: the reason is in the result, so the only failure the client
sees from the cluster is the loss of a worker.

Inputs are read, and shared outputs written, at the absolute paths the client names:
workers see the same paths (a shared file system). With `collect` the outputs come back
as bytes instead and the client writes them.
"""
from __future__ import annotations

import functools
import os
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field

from ..core.subdivision_modes import FILE_DEFAULT
from ..core.text import error_text, frame_path, one_line

# Dask worker resources. A worker offers `bpy` when it can run Blender (a subprocess per
# export), `gl` when it can make an EGL context, and `GPU` when it has a GPU of its own
# (the one its LANTERN_GPU names); a task is only ever given to a worker that offers
# what it needs. Render chunks ask for a GPU where the cluster offers one (`gpu`).
EXPORT_NEEDS = {"bpy": 1}
RENDER_NEEDS = {"gl": 1}
GPU_RENDER_NEEDS = {**RENDER_NEEDS, "GPU": 1}

INTERRUPTED = 130


@dataclass(frozen=True)
class ExportTask:
    blend: str                      # absolute path, read by the worker
    output: str                     # absolute path the client wants the layer at
    textures: str = "reference"
    max_influences: int | None = None
    collect: bool = False           # return the files instead of writing `output`
    subdivision: str = FILE_DEFAULT
    needs = EXPORT_NEEDS

    @property
    def label(self):
        return os.path.basename(self.blend)

    @property
    def outputs(self):
        return [self.output]


@dataclass(frozen=True)
class ChunkOutput:
    """One file per frame of a chunk (a product, farm/options.py)."""
    pattern: str | None             # output name ('####' = the frame); None: return pixels
    width: int | None = None
    height: int | None = None
    camera: str | None = None
    passes: tuple = ()              # render passes
    layer: str = "ViewLayer"
    layered: bool = False           # a multi-layer EXR (engine/image_io.py write_layers)


@dataclass(frozen=True)
class RenderChunk:
    scene: str                      # the file the user named: messages and the cache key
    frames: tuple                   # frames to render, in order
    targets: tuple                  # ChunkOutput, each written for every frame
    preset: str = "medium"
    stage_digest: str | None = None  # set when the stage comes as text (a .blend's export)
    collect: bool = False
    # Outputs at least this new (the output folder's own clock) were written by this
    # run: a chunk run again after its worker died skips the frames already written.
    since_ns: int | None = None
    # Blender's colour management for .png outputs (engine/color.py): view, look, exposure.
    colour: tuple = ("Standard", None, 0.0)
    overlays: object = None     # engine/overlays.py BurnIn: drawn on each .png
    gpu: bool = False           # ask the cluster for a worker's GPU (GPU_RENDER_NEEDS)

    @property
    def needs(self):
        return GPU_RENDER_NEEDS if self.gpu else RENDER_NEEDS

    @property
    def label(self):
        first, last = self.frames[0], self.frames[-1]
        return f"frame {first:g}" if len(self.frames) == 1 else f"frames {first:g}-{last:g}"

    @property
    def outputs(self):
        return [frame_path(t.pattern, f) for t in self.targets if t.pattern
                for f in self.frames]

    @property
    def settings_key(self):
        """A worker's session is reconfigured for each target (size, camera, passes):
        only the preset sets it apart."""
        return (self.preset,)


@dataclass
class TaskResult:
    ok: bool
    seconds: float                  # on the worker, from start to end of the task
    worker: str
    warnings: list = field(default_factory=list)
    reason: str = ""                # why it failed, one line naming the file
    files: dict = field(default_factory=dict)    # collected outputs: path -> bytes
    written: list = field(default_factory=list)  # frames written (or collected)
    skipped: list = field(default_factory=list)  # frames a lost attempt had written
    pixels: dict = field(default_factory=dict)   # frame -> rgba, for a .gif
    failed: dict = field(default_factory=dict)   # frame -> why it was not rendered
    cold: float | None = None       # stage load + first render, when this task loaded it
    warm: list = field(default_factory=list)     # seconds of each warm render
    device: str = ""                # the GPU the frames were drawn on, from their stats


def run(task, stage_text=None):
    """The one entry point workers call."""
    if isinstance(task, ExportTask):
        return run_export(task)
    return run_chunk(task, stage_text)


def preload(slot=None):
    """What every render worker needs, done before its first task: the engine's
    imports, the image writers and the GL context, on the GPU of worker `slot` of this
    machine (engine/gpu/devices.py). A context that cannot be made is said by each
    chunk, with its reason."""
    from ..engine.gpu import devices
    from ..engine.gpu.context import run_gl
    from ..engine.image_io import write_image  # noqa: F401
    from . import sessions  # noqa: F401
    if slot is not None:
        devices.assign_worker(slot)
    try:
        run_gl(lambda gl: None)
    except RuntimeError:
        pass


def device_text(stats) -> str:
    """'EGL device 0: llvmpipe (...)' from a render's stats."""
    index = stats.get("gpu_device")
    where = "default GL context" if index is None else f"EGL device {index}"
    return f"{where}: {stats.get('gl_renderer', '?')}"


def worker_name():
    """The Dask worker's address, else this process ("local pid N")."""
    distributed = sys.modules.get("distributed")  # a Dask worker has it imported
    if distributed is not None:
        try:
            return distributed.get_worker().address
        except ValueError:
            pass
    return f"local pid {os.getpid()}"


# --- export -----------------------------------------------------------------------------

def _parent_death_signal():
    """A function for the export's child, between fork and exec: die when the worker
    that started it dies (Linux's PR_SET_PDEATHSIG), so a lost worker leaves no Blender
    behind still writing its output. libc is looked up here, in the parent: the child
    of a threaded worker only makes the one call."""
    try:
        import ctypes
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):  # not Linux
        return None
    pr_set_pdeathsig, sigkill = 1, 9
    return lambda: prctl(pr_set_pdeathsig, sigkill)


_DIE_WITH_PARENT = _parent_death_signal() if sys.platform.startswith("linux") else None


def run_export(task: ExportTask) -> TaskResult:
    """A fresh Blender per file: `lantern export` in a subprocess. A file that crashes
    Blender fails alone, the worker survives it, and each file gets an empty bpy."""
    start = time.perf_counter()
    folder = tempfile.mkdtemp(prefix="lantern-export-") if task.collect else None
    target = os.path.join(folder, os.path.basename(task.output)) if folder else task.output
    command = [sys.executable, "-m", "lantern", "export", task.blend, "-o", target,
               "--textures", task.textures, "--subdivision", task.subdivision]
    if task.max_influences is not None:
        command += ["--max-influences", str(task.max_influences)]
    try:
        proc = subprocess.run(command, capture_output=True, text=True,
                              preexec_fn=_DIE_WITH_PARENT)
        warnings = [line.removeprefix("warning: ") for line in proc.stderr.splitlines()
                    if line.startswith("warning: ")]
        result = TaskResult(ok=proc.returncode == 0, seconds=0.0, worker=worker_name(),
                            warnings=warnings)
        if proc.returncode != 0:
            reason = [line.removeprefix("lantern export: ") for line in proc.stderr.splitlines()
                      if line.strip() and not line.startswith("warning: ")]
            if proc.returncode == INTERRUPTED:
                reason.append("interrupted")
            elif proc.returncode < 0:
                reason.append(f"Blender crashed (signal {-proc.returncode})")
            result.reason = reason[-1] if reason else "unknown error"
        elif folder:
            result.files = _read_tree(folder, os.path.dirname(task.output))
    finally:
        if folder:
            import shutil
            shutil.rmtree(folder, ignore_errors=True)
    result.seconds = time.perf_counter() - start
    return result


def _read_tree(folder, destination):
    """Every file under `folder` (the layer and its `<stem>_textures/`), keyed by where
    it goes under `destination`."""
    files = {}
    for root, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(root, name)
            with open(path, "rb") as f:
                files[os.path.join(destination, os.path.relpath(path, folder))] = f.read()
    return files


# --- render -----------------------------------------------------------------------------

# One chunk at a time per process: the engine draws on one GL thread, and a Session is
# not shared between threads.
_render_lock = threading.Lock()


def run_chunk(task: RenderChunk, stage_text=None) -> TaskResult:
    """Renders the chunk's frames with the worker's Session for the stage, writing (or
    encoding, with collect) each image as it comes, as today's one-process loop does:
    a writer thread measured no faster on 2 cores (bench/bench_distributed.py)."""
    from . import sessions
    start = time.perf_counter()
    result = TaskResult(ok=True, seconds=0.0, worker=worker_name())
    with _render_lock:
        try:
            session, load = sessions.session_for(task, stage_text)
        except (OSError, ValueError, RuntimeError) as error:
            # The stage could not be loaded: every frame of the chunk fails for it.
            result.reason = f"{task.scene}: {one_line(error_text(error))}"
            result.failed = {frame: result.reason for frame in task.frames}
        else:
            _render_frames(task, session, load, result)
    result.ok = not result.failed
    if result.failed and not result.reason:
        result.reason = next(iter(result.failed.values()))
    result.seconds = time.perf_counter() - start
    return result


def _render_frames(task, session, load, result):
    """The chunk's frames into `result`: written, skipped (a lost attempt wrote them)
    or failed; each target in turn, the session reconfigured for it. Frame N+1 is
    drawn while frame N is copied and written (Session.render_frames)."""
    todo = []
    for frame in task.frames:
        paths = [frame_path(t.pattern, frame) for t in task.targets if t.pattern]
        if paths and not task.collect and all(_written_since(p, task.since_ns) for p in paths):
            result.skipped.append(frame)
        else:
            todo.append(frame)
    for target in task.targets:
        session.configure(width=target.width, height=target.height, camera=target.camera,
                          passes=frozenset(target.passes))
        t0 = time.perf_counter()
        for frame, image in session.render_frames(todo):
            seconds, t0 = time.perf_counter() - t0, time.perf_counter()
            if isinstance(image, Exception):      # the engine's input errors
                result.failed.setdefault(
                    frame, f"{task.scene}: frame {frame:g}: {one_line(error_text(image))}")
                continue
            if result.cold is None and load is not None:
                result.cold = load + seconds        # the load counts in the first frame
            else:
                result.warm.append(seconds)
            result.warnings += [w for w in image.warnings if w not in result.warnings]
            result.device = result.device or device_text(image.stats)
            path = frame_path(target.pattern, frame) if target.pattern else None
            _keep(task, target, frame, path, image, result)
            t0 = time.perf_counter()
    result.written += [f for f in todo if f not in result.failed]


def _keep(task, target, frame, path, image, result):
    """A rendered frame written, encoded (collect) or kept in memory."""
    try:
        if path is None:
            result.pixels[frame] = image.rgba
        elif task.collect:
            result.files[path] = _encoded(path, target, image, task.colour, _overlay(task, frame))
        else:
            _write(path, target, image, task.colour, _overlay(task, frame))
    except (OSError, ValueError) as error:
        result.failed.setdefault(frame, f"{path}: cannot be written: "
                                        f"{getattr(error, 'strerror', None) or error}")


def _written_since(path, since_ns):
    if since_ns is None:
        return False
    try:
        return os.stat(path).st_mtime_ns >= since_ns
    except OSError:
        return False


def _colour_settings(colour):
    view, look, exposure = colour
    return dict(view=view, look=look, exposure=exposure)


def _overlay(task, frame):
    return None if task.overlays is None else functools.partial(task.overlays.apply,
                                                                 frame=frame)


def _write(path, target, image, colour, overlay=None):
    """One frame's file: a multi-layer EXR of the target's passes, else the image."""
    from ..engine.image_io import write_image, write_layers
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    if target.layered:
        write_layers(path, image.rgba, image.passes, target.layer, image.cryptomatte)
    else:
        write_image(path, image.rgba, **_colour_settings(colour), overlay=overlay)


def _encoded(path, target, image, colour, overlay=None):
    """The image file's bytes, encoded here (the worker) so only the file travels."""
    with tempfile.TemporaryDirectory(prefix="lantern-frame-") as folder:
        local = os.path.join(folder, "frame" + os.path.splitext(path)[1])
        _write(local, target, image, colour, overlay)
        with open(local, "rb") as f:
            return f.read()
