"""The client side of a batch: which tasks to run, running them, and the summary.

`export_batch` and `render_frames` are what `lantern export` (several files) and
`lantern render --frames` call, with or without `--scheduler`. Both:
- skip, with `--resume`, outputs that exist and are newer than their inputs (a file at
  an output's name is complete: every write is a temporary name and a rename);
- run the tasks on a runner (runners.py) with a progress bar;
- write the outputs that come back with `--collect` (atomically, here);
- after a lost worker, remove the temporary files its task left in the shared folder;
- report each failure once with its reason, and each task that ran again because its
  worker died; print the summary table; return the exit status (1 if anything failed).
"""
from __future__ import annotations

import hashlib
import os
import re
import statistics
import sys
import tempfile
from collections import deque
from dataclasses import dataclass, field
from typing import NamedTuple

from ..core import interrupt
from ..core.files import atomic_write
from ..core.text import frame_path
from . import chunking
from .options import ExportBatchOptions, SequenceOptions
from .runners import FarmError, open_runner
from .tasks import EXPORT_NEEDS, GPU_RENDER_NEEDS, RENDER_NEEDS, ChunkOutput, ExportTask, RenderChunk

FAILED = 1
STALL_SECONDS = 5.0  # how often a waiting client checks that some worker can run its tasks


def _needs_text(needs):
    return ",".join(f"{k}={v}" for k, v in needs.items())


def _progress():
    from rich.console import Console
    from rich.progress import Progress
    return Progress(console=Console(stderr=True), transient=True)


def _table(title, columns):
    from rich.table import Table
    table = Table(title=title)
    for column in columns:
        table.add_column(column, overflow="fold")
    return table


def _print(table):
    from rich.console import Console
    Console(width=max(160, Console().width)).print(table)


def _drive(runner, submit_more, on_done, needs, status=None):
    """Waits for every task, calling on_done for each finished one and submit_more
    after it; gives the rest up if no worker can run them any more. status(state): the
    farm's progress for --status-fd (FarmOptions.status)."""
    submit_more()
    if status is not None:
        status("running")
    while runner.pending:
        interrupt.check()           # a Ctrl-C that USD swallowed while the stage was read
        finished = runner.wait(timeout=STALL_SECONDS)
        if not finished and not runner.offers(needs):
            finished = runner.fail_pending(f"no worker offers {_needs_text(needs)} any more")
        for done in finished:
            on_done(done)
        submit_more()
    if status is not None:
        status("finished")


def open_render_runner(scheduler, jobs):
    """The runner for a sequence (FarmOptions' scheduler and jobs), opened before the
    client reads the stage: local workers import the engine meanwhile."""
    return open_runner(scheduler, jobs, render=True)


def _open(options, needs, runner=None):
    runner = runner or open_runner(options.scheduler, options.jobs)
    if not runner.offers(needs):
        runner.close()
        raise FarmError(f"{options.scheduler}: no worker offers {_needs_text(needs)} (start "
                        f"workers with --resources \"{_needs_text(needs)}\")")
    if runner.dashboard:
        print(f"dashboard: {runner.dashboard}", file=sys.stderr, flush=True)
    return runner


def _up_to_date(output, input_mtime_ns):
    try:
        stat = os.stat(output)
    except OSError:
        return False
    return stat.st_size > 0 and stat.st_mtime_ns > input_mtime_ns


def _write_collected(files):
    for path, data in files.items():
        os.makedirs(os.path.dirname(path), exist_ok=True)

        def write(tmp, data=data):
            with open(tmp, "wb") as f:
                f.write(data)
        atomic_write(path, write, suffix=os.path.splitext(path)[1])


def _sweep(outputs):
    """Removes what a lost or killed worker's atomic writes left:
    `.<name>.XXXXXXXX<suffix>` beside each output (core/files.py's temporary names).
    An output may be a frame pattern ('####'): every frame's are removed."""
    for output in outputs:
        folder, name = os.path.split(output)
        stem = "".join(r"\d+(?:\.\d+)?" if part.startswith("#") else re.escape(part)
                       for part in re.split(r"(#+)", name) if part)
        pattern = re.compile(r"\." + stem + r"\.[a-z0-9_]{8}"
                             + re.escape(os.path.splitext(name)[1]) + "$")
        try:
            names = os.listdir(folder)
        except OSError:
            continue
        for leftover in filter(pattern.match, names):
            try:
                os.remove(os.path.join(folder, leftover))
            except OSError:
                pass


def _folder_clock(folder):
    """Now, on the output folder's own clock (a file system shared by machines whose
    clocks differ): the mtime of a file made and removed there."""
    fd, path = tempfile.mkstemp(prefix=".lantern-clock-", dir=folder)
    try:
        return os.fstat(fd).st_mtime_ns
    finally:
        os.close(fd)
        os.remove(path)


def _retry_line(label, done):
    workers = ", ".join(done.lost)
    where = f", then ran on {done.result.worker}" if done.result else ""
    return f"retried: {label}: its worker died while running it ({workers}){where}"


# --- export -----------------------------------------------------------------------------

class _ExportRow(NamedTuple):
    """One line of the export summary."""
    blend: str
    status: str             # ok, skipped or failed
    seconds: float
    warnings: int
    worker: str
    tries: int
    detail: str             # the output, or why it failed


def export_batch(options: ExportBatchOptions, jobs):
    """jobs: [(blend, output)] in the order given. Returns the exit status."""
    tasks, rows, skipped = [], {}, []
    for blend, output in jobs:
        if options.resume and os.path.isfile(blend) and \
                _up_to_date(output, os.stat(blend).st_mtime_ns):
            skipped.append(blend)
            rows[blend] = _ExportRow(blend, "skipped", 0.0, 0, "", 1, f"{output} (up to date)")
            continue
        tasks.append(ExportTask(os.path.abspath(blend), os.path.abspath(output),
                                options.textures, options.max_influences, options.collect,
                                options.subdivision))
    retries, lost_outputs = [], []
    if tasks:
        runner = _open(options, EXPORT_NEEDS)
        queue = deque(tasks)
        try:
            with _progress() as progress:
                bar = progress.add_task("exporting", total=len(tasks))

                def submit_more():
                    while queue:
                        runner.submit(queue.popleft())

                def on_done(done):
                    task, result = done.task, done.result
                    blend = next(b for b, o in jobs if os.path.abspath(b) == task.blend)
                    tries = 1 + len(done.lost)
                    if done.lost:
                        retries.append(_retry_line(os.path.basename(blend), done))
                        lost_outputs.extend(task.outputs)
                    if result is None:
                        rows[blend] = _ExportRow(blend, "failed", done.latency, 0, "", tries,
                                                 done.error)
                    elif result.ok:
                        _write_collected(result.files)
                        rows[blend] = _ExportRow(blend, "ok", result.seconds,
                                                 len(result.warnings), result.worker, tries,
                                                 task.output)
                    else:
                        rows[blend] = _ExportRow(blend, "failed", result.seconds,
                                                 len(result.warnings), result.worker, tries,
                                                 result.reason)
                    progress.advance(bar)

                _drive(runner, submit_more, on_done, EXPORT_NEEDS, options.status)
        except BaseException:
            runner.close(interrupted=True)
            _sweep(task.output for task in tasks)     # what the killed workers left
            raise
        else:
            runner.close()
        if not options.collect:
            _sweep(lost_outputs)

    table = _table("lantern export", ("file", "status", "seconds", "warnings", "worker",
                                      "tries", "output / reason"))
    ordered = [rows[blend] for blend, _ in jobs]
    for row in ordered:
        style = {"ok": "green", "skipped": "blue"}.get(row.status, "red")
        table.add_row(os.path.basename(row.blend), f"[{style}]{row.status}[/]",
                      f"{row.seconds:.2f}", str(row.warnings), row.worker, str(row.tries),
                      row.detail)
    _print(table)
    for line in retries:
        print(line)
    failed = sum(1 for row in ordered if row.status == "failed")
    exported = sum(1 for row in ordered if row.status == "ok")
    tail = f", {len(skipped)} skipped (up to date)" if skipped else ""
    print(f"{exported} exported, {failed} failed{tail}")
    return FAILED if failed else 0


# --- render -----------------------------------------------------------------------------

class _Costs:
    """What the finished chunks measured: cold, warm and per-task overhead (seconds)."""

    def __init__(self):
        self.cold, self.warm, self.overhead, self.chunks = [], [], None, 0

    def add(self, done):
        result = done.result
        self.chunks += 1
        if result.cold is not None:
            self.cold.append(result.cold)
        self.warm += result.warm
        if not done.lost:
            overhead = max(0.0, done.latency - result.seconds)
            self.overhead = overhead if self.overhead is None else min(self.overhead, overhead)

    @property
    def measured(self):
        return self.chunks > 0

    def chunk(self, left, workers):
        cold = max(self.cold, default=0.0)
        warm = statistics.median(self.warm) if self.warm else cold
        return chunking.chunk_size(cold, warm, self.overhead or 0.0, left, workers)


def _frames_text(frames):
    """1-4, 7, 9-12 for the frames given (in order)."""
    runs, start, prev = [], None, None
    for frame in sorted(frames):
        if start is not None and frame == prev + 1:
            prev = frame
            continue
        if start is not None:
            runs.append(f"{start:g}" if start == prev else f"{start:g}-{prev:g}")
        start = prev = frame
    if start is not None:
        runs.append(f"{start:g}" if start == prev else f"{start:g}-{prev:g}")
    return ", ".join(runs)


@dataclass
class _WorkerTally:
    """What one worker did in a sequence, for the summary table."""
    chunks: int = 0
    frames: int = 0
    seconds: float = 0.0
    cold: list = field(default_factory=list)    # seconds of each chunk that loaded the stage
    warm: list = field(default_factory=list)    # seconds of each warm render
    device: str = ""                            # the GPU it drew on


def render_frames(options: SequenceOptions, runner, stage_text=None, fps=24.0,
                  print_warnings=None):
    """Renders options.frames of options.scene into each of options.products ('####',
    or one .gif) as chunks on `runner` (open_render_runner), which it closes.
    stage_text: the stage as USD text when the client exported it (a .blend)."""
    try:
        status = _render_frames(options, runner, stage_text, fps, print_warnings)
    except BaseException:
        runner.close(interrupted=True)
        if not options.output.lower().endswith(".gif"):
            # What the killed workers left.
            _sweep([os.path.abspath(p.output) for p in options.products])
        raise
    return status


def _render_frames(options, runner, stage_text, fps, print_warnings):
    gif = options.output.lower().endswith(".gif")
    patterns = [] if gif else [os.path.abspath(p.output) for p in options.products]
    scene = os.path.abspath(options.scene)
    input_mtime = os.stat(scene).st_mtime_ns
    frames = list(options.frames)
    up_to_date = []
    if options.resume:
        if gif:
            up_to_date = frames if _up_to_date(options.output, input_mtime) else []
        else:
            up_to_date = [f for f in frames if all(_up_to_date(frame_path(p, f), input_mtime)
                                                   for p in patterns)]
        frames = [f for f in frames if f not in set(up_to_date)]
    if not frames:
        runner.close()
        print(f"0 frames written, 0 failed, {len(up_to_date)} skipped (up to date)")
        return 0
    folder = os.path.dirname(os.path.abspath(options.output))
    for product in options.products:
        os.makedirs(os.path.dirname(os.path.abspath(product.output)), exist_ok=True)
    digest = hashlib.sha1(stage_text.encode()).hexdigest() if stage_text is not None else None
    targets = tuple(ChunkOutput(None if gif else os.path.abspath(p.output),
                                *(p.size or (None, None)), p.camera, tuple(p.passes), p.layer,
                                p.layered)
                    for p in options.products)
    base = dict(scene=scene, targets=targets, preset=options.preset,
                stage_digest=digest, collect=options.collect,
                colour=(options.view, options.look, options.exposure),
                overlays=options.overlays,
                since_ns=None if (options.collect or gif) else _folder_clock(folder))

    _open(options, RENDER_NEEDS, runner)
    # Chunks go to the workers' GPUs where the cluster offers them, else to any with GL.
    gpu = runner.offers(GPU_RENDER_NEEDS)
    needs = GPU_RENDER_NEEDS if gpu else RENDER_NEEDS
    base["gpu"] = gpu
    workers = max(1, runner.workers(needs))
    left = deque(frames)
    costs = _Costs()
    pixels, failed, per_worker, retries, lost_outputs = {}, {}, {}, [], []
    written = skipped_lost = 0
    first = [] if options.chunk else chunking.first_wave(frames, workers)
    for chunk in first:
        for _ in chunk:
            left.popleft()

    def submit(chunk):
        runner.submit(RenderChunk(frames=tuple(chunk), **base), stage_text)

    with _progress() as progress:
        bar = progress.add_task("rendering", total=len(frames))

        def submit_more():
            while first:
                submit(first.pop(0))
            # Two chunks per worker in flight: a worker never waits for its next.
            while left and runner.pending < 2 * workers and (options.chunk or costs.measured):
                size = options.chunk or costs.chunk(len(left), workers)
                submit([left.popleft() for _ in range(min(size, len(left)))])
            if left and not runner.pending:  # nothing measured: every chunk failed
                for frame in left:
                    failed[frame] = "not rendered: every chunk before it failed"
                left.clear()

        def on_done(done):
            nonlocal written, skipped_lost
            task, result = done.task, done.result
            if done.lost:
                retries.append(_retry_line(task.label, done))
                lost_outputs.extend(task.outputs)
            if result is None:
                for frame in task.frames:
                    failed[frame] = done.error
                progress.advance(bar, len(task.frames))
                return
            print_warnings(result.warnings)
            tally = per_worker.setdefault(result.worker, _WorkerTally())
            tally.chunks += 1
            tally.frames += len(result.written)
            tally.seconds += result.seconds
            if result.cold is not None:
                tally.cold.append(result.cold)
            tally.warm += result.warm
            tally.device = result.device or tally.device
            if result.written or result.skipped:
                costs.add(done)
            _write_collected(result.files)
            pixels.update(result.pixels)
            written += len(result.written)
            skipped_lost += len(result.skipped)
            failed.update(result.failed)
            progress.advance(bar, len(task.frames))

        _drive(runner, submit_more, on_done, needs, options.status)
    dashboard = runner.dashboard
    runner.close()
    if patterns and not options.collect:
        _sweep(lost_outputs)
    if gif and not failed:
        from ..engine.image_io import write_animation
        images = [pixels[f] for f in sorted(pixels)]
        write_animation(options.output, images, fps, **options.colour)

    table = _table(f"lantern render ({runner.name})",
                   ("worker", "device", "chunks", "frames", "seconds", "cold s",
                    "warm ms/frame"))
    for worker, tally in sorted(per_worker.items()):
        table.add_row(worker, tally.device or "-", str(tally.chunks), str(tally.frames),
                      f"{tally.seconds:.2f}", f"{max(tally.cold):.2f}" if tally.cold else "-",
                      f"{statistics.median(tally.warm) * 1000:.1f}" if tally.warm else "-")
    _print(table)
    if dashboard:
        print(f"dashboard: {dashboard}")
    for line in retries:
        print(line)
    if skipped_lost:
        print(f"{skipped_lost} frames written by a lost worker before it died were kept, "
              "not rendered again")
    reasons = {}
    for frame, reason in failed.items():
        reasons.setdefault(reason, []).append(frame)
    for reason, frames_failed in reasons.items():
        print(f"failed: frames {_frames_text(frames_failed)}: {reason}")
    tail = f", {len(up_to_date)} skipped (up to date)" if up_to_date else ""
    where = options.output if gif else os.path.dirname(options.output) or "."
    print(f"{written + skipped_lost} frames written, {len(failed)} failed{tail} -> {where}")
    return FAILED if failed else 0


__all__ = ["FarmError", "export_batch", "open_render_runner", "render_frames"]
