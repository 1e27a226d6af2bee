"""Runs worker jobs (worker.py) as processes, --jobs at a time, with one progress bar
over every render they make.

Each job's spec, result and full output (Blender's and Lantern's own messages) stay
in DIR/logs/ for anyone who wants to see what happened. Renders of different jobs
overlap only when --jobs > 1; their times then share the machine's cores, which the
report says."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from .files import write_json
from .modes import PROGRESS


@dataclass
class Job:
    name: str            # e.g. "cycles direct", "lantern high"; unique in a run
    spec: dict           # worker spec, without name/result (filled in here)
    renders: int         # progress lines the job prints
    result: dict | None = None
    error: str | None = None
    seconds: float = 0.0
    log: str = ""
    extra: dict = field(default_factory=dict)  # what the parent needs to read the result
    reported: int = 0    # progress lines seen so far


def _slug(name):
    return "".join(c if c.isalnum() else "_" for c in name)


def _last_error(log_path, returncode):
    if returncode < 0:
        return f"the process crashed (signal {-returncode})"
    try:
        with open(log_path, encoding="utf-8", errors="replace") as f:
            lines = [line.strip() for line in f if line.strip()]
    except OSError:
        lines = []
    errors = [line for line in lines if line.startswith("error: ")]
    if errors:
        return errors[-1].removeprefix("error: ")
    return lines[-1] if lines else f"exit status {returncode}"


def run_job(job: Job, log_dir: str, on_progress) -> Job:
    slug = _slug(job.name)
    spec_path = os.path.join(log_dir, f"{slug}.spec.json")
    result_path = os.path.join(log_dir, f"{slug}.result.json")
    job.log = os.path.join(log_dir, f"{slug}.log")
    if os.path.exists(result_path):
        os.remove(result_path)
    spec = dict(job.spec, name=job.name, result=result_path)
    spec["spawned_at"] = time.time()
    write_json(spec_path, spec)
    start = time.perf_counter()
    with open(job.log, "w", encoding="utf-8") as log:
        # -u: progress lines arrive as each render ends, not when the buffer fills.
        proc = subprocess.Popen([sys.executable, "-u", "-m", "lantern.compare.worker", spec_path],
                                stdout=subprocess.PIPE, stderr=log, text=True, errors="replace")
        for line in proc.stdout:
            if line.startswith(PROGRESS):
                on_progress(job, json.loads(line[len(PROGRESS):]))
            else:
                log.write(line)
        proc.wait()
    job.seconds = time.perf_counter() - start
    if proc.returncode == 0 and os.path.exists(result_path):
        with open(result_path, encoding="utf-8") as f:
            job.result = json.load(f)
    else:
        job.error = _last_error(job.log, proc.returncode)
    return job


def run_jobs(jobs, parallel: int, log_dir: str, quiet: bool = False):
    """Runs `jobs` (in order, `parallel` at a time); returns them with result or error."""
    from rich.console import Console
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                               TimeElapsedColumn)
    os.makedirs(log_dir, exist_ok=True)
    console = Console(stderr=True, quiet=quiet)
    lock = threading.Lock()
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=console) as progress:
        bar = progress.add_task("rendering", total=sum(j.renders for j in jobs))

        def on_progress(job, fields):
            what = f"{job.name}" + (f" {fields['samples']} spp" if "samples" in fields else "")
            with lock:
                job.reported += 1
                progress.update(bar, advance=1, description=f"{what}: {fields['seconds']:.2f} s")

        def run(job):
            done = run_job(job, log_dir, on_progress)
            if done.error is not None:
                with lock:  # the bar still reaches its end
                    progress.update(bar, description=f"{job.name} failed: {done.error}")
                    progress.advance(bar, max(0, job.renders - job.reported))
            return done

        with ThreadPoolExecutor(max_workers=max(1, parallel)) as pool:
            return list(pool.map(run, jobs))

