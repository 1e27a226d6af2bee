"""Where tasks run: the local process pool, or a Dask cluster.

Both runners take the same tasks (tasks.py) and hand back the same `Done` records:

- `PoolRunner`: processes on this machine, started by Lantern (the default: it measured
  better than a LocalCluster on one machine, see docs/status.md). Spawned, SIGINT ignored (the
  client alone answers Ctrl-C), one task at a time each, kept for the whole batch so a
  process keeps its Sessions. A process that dies mid-task is replaced and its task
  runs again on another, up to RETRIES times. Process k draws on GPU k mod the
  number of GPUs (engine/gpu/devices.py), its replacement on the same.
- `DaskRunner`: a Dask cluster: an existing scheduler (`tcp://HOST:PORT`) or an
  embedded LocalCluster (`local`), whose workers spread over this machine's GPUs as
  dask-cuda's LocalCUDACluster does (each its own LANTERN_GPU and a `GPU` resource).
  Tasks carry their worker resources (`bpy`, `gl`, `GPU`), so a worker is only given
  what it offers. The scheduler itself reruns a task whose
  worker died (up to its `distributed.scheduler.allowed-failures`, 3 by default); the
  runner hears of each loss through the scheduler's `remove-worker` events.
"""
from __future__ import annotations

import logging
import multiprocessing
import time
import uuid
from collections import deque
from dataclasses import dataclass, field
from multiprocessing.connection import wait as wait_for_any

from ..core import interrupt
from . import tasks as farm_tasks

RETRIES = 3  # a pool task runs at most 1 + RETRIES times when its process dies
# Render chunks sent to a pool process at once: one running, one waiting (exports take
# seconds each: one at a time, so a free process takes the next file).
PIPELINE = 2


class FarmError(Exception):
    """The cluster cannot be used (cannot connect, no suitable worker): one line."""


@dataclass
class Done:
    task: object
    result: farm_tasks.TaskResult | None   # None when the task never finished
    error: str = ""                         # why not
    lost: list = field(default_factory=list)  # workers that died while running it
    latency: float = 0.0                    # seconds from dispatch to the client's hands


def _key(task):
    kind = "export" if isinstance(task, farm_tasks.ExportTask) else "render"
    return f"lantern-{kind}-{task.label.replace(' ', '-')}-{uuid.uuid4().hex[:8]}"


# --- the local pool ---------------------------------------------------------------------

def _serve(conn, preload, slot):
    """A pool process, worker `slot` of the pool: run tasks until told to stop, then
    release the sessions."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):   # started with it blocked: see _Process
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:
        if preload:
            farm_tasks.preload(slot)
        while True:
            message = conn.recv()
            if message is None:
                break
            task, stage_text = message
            try:
                conn.send((farm_tasks.run(task, stage_text), ""))
            except Exception as error:  # a bug in a task: its own failure, not the pool's
                conn.send((None, f"internal error: {type(error).__name__}: {error}"))
    except (EOFError, KeyboardInterrupt):
        pass
    finally:
        from . import sessions
        sessions.release_all()


class _Process:
    def __init__(self, context, preload, slot):
        import signal
        self.slot = slot
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child, preload, slot),
                                       daemon=True)
        # Ctrl-C reaches the whole process group, and only the client answers it,
        # even while a new process is still importing: the worker starts with SIGINT
        # blocked (the mask is kept across exec) and ignores it before unblocking.
        # Blocking, not ignoring, in the client meanwhile: an ignored Ctrl-C that
        # arrived while a worker started was lost, a blocked one comes after.
        # A Ctrl-C that lands on another thread meanwhile is raised once the start is
        # whole (interrupt.deferred), not in the middle of handing the child its data.
        if hasattr(signal, "pthread_sigmask"):
            with interrupt.deferred():
                signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
                try:
                    self.process.start()
                finally:
                    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        else:                                 # Windows: no signal masks
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                self.process.start()
            finally:
                signal.signal(signal.SIGINT, previous)
        child.close()
        self.jobs: deque[_Job] = deque()  # sent, in order; the first is running

    @property
    def name(self):
        return f"local pid {self.process.pid}"


@dataclass
class _Job:
    task: object
    stage_text: str | None
    lost: list = field(default_factory=list)
    sent: float = 0.0


class PoolRunner:
    name = "local processes"
    dashboard = None

    def __init__(self, processes, render=False):
        """render: the processes import the engine and make their GL context as soon
        as they start, while the client still reads the stage."""
        self.size = max(1, processes)
        self._context = multiprocessing.get_context("spawn")
        self._queue: deque[_Job] = deque()
        self._render = render
        self._processes = [_Process(self._context, render, k) for k in range(self.size)] \
            if render else []

    def workers(self, needs=None):
        return self.size if self.offers(needs or {}) else 0

    def offers(self, needs):
        # This machine runs Blender and GL, as `lantern` always has; a GPU is no
        # resource here (the processes spread over the GPUs there are).
        return set(needs) <= {"bpy", "gl"}

    def _new_process(self):
        free = min(set(range(self.size)) - {p.slot for p in self._processes})
        self._processes.append(_Process(self._context, self._render, free))

    @property
    def pending(self):
        return len(self._queue) + sum(len(p.jobs) for p in self._processes)

    def submit(self, task, stage_text=None):
        self._queue.append(_Job(task, stage_text))

    def _dispatch(self):
        """Sends queued jobs: to a process with none first, else (render chunks) as a
        second behind its running one, so a process never waits for the client
        between chunks."""
        while self._queue:
            if len(self._processes) < self.size and all(p.jobs for p in self._processes):
                self._new_process()
            proc = min(self._processes, key=lambda p: len(p.jobs))
            if len(proc.jobs) >= (PIPELINE if self._render else 1):
                return
            job = self._queue.popleft()
            job.sent = time.perf_counter()
            proc.conn.send((job.task, job.stage_text))
            proc.jobs.append(job)

    def wait(self, timeout=None):
        self._dispatch()
        busy = [p for p in self._processes if p.jobs]
        if not busy:
            return []
        wakeup = interrupt.wakeup_fd()       # Ctrl-C ends the wait, whatever thread got it
        ready = set(wait_for_any([p.conn for p in busy] + [p.process.sentinel for p in busy]
                                 + ([wakeup] if wakeup is not None else []), timeout))
        if wakeup in ready:
            interrupt.drain()
        done = []
        for proc in busy:
            if proc.conn not in ready and proc.process.sentinel not in ready:
                continue
            try:
                while proc.jobs and proc.conn.poll():
                    result, error = proc.conn.recv()
                    job = proc.jobs.popleft()
                    done.append(Done(job.task, result, error, job.lost,
                                     time.perf_counter() - job.sent))
            except (EOFError, OSError):
                pass
            if proc.process.is_alive() or not proc.jobs:
                continue
            # The process died: its running job is lost with it and runs again (up to
            # RETRIES times); a job queued behind it never started and simply goes back.
            self._processes.remove(proc)
            proc.process.join(1)
            running, *waiting = proc.jobs
            running.lost.append(proc.name)
            self._queue.extendleft(reversed(waiting))
            if len(running.lost) > RETRIES:
                done.append(Done(running.task, None, f"its worker died {len(running.lost)} times",
                                 running.lost, time.perf_counter() - running.sent))
            else:
                self._queue.appendleft(running)
        self._dispatch()
        return done

    def fail_pending(self, reason):
        return []  # never needed: this machine offers every resource

    def close(self, interrupted=False):
        for proc in self._processes:
            try:
                if interrupted:
                    proc.process.kill()
                else:
                    proc.conn.send(None)
            except (OSError, ValueError):
                pass
        for proc in self._processes:
            proc.process.join(10)
            if proc.process.is_alive():
                proc.process.kill()
                proc.process.join(1)
        self._processes = []


# --- Dask -------------------------------------------------------------------------------

def _release_plugin():
    from distributed import WorkerPlugin

    class ReleaseSessions(WorkerPlugin):
        """Releases the worker's cached Sessions (their GL state) when it closes.
        Idempotent: registered again by every client, it must not be torn down (and
        the sessions with it) each time."""
        idempotent = True

        def teardown(self, worker):
            from lantern.farm import sessions
            sessions.release_all()

    return ReleaseSessions()


def local_cluster(workers, gpus=None, **options):
    """An embedded Dask LocalCluster of `workers` processes offering `bpy` and `gl`.
    `gpus` (default: this machine's GPUs, none when LANTERN_GPU already chose one):
    worker k gets LANTERN_GPU = gpus[k mod len(gpus)] and a `GPU` resource, as
    dask-cuda's LocalCUDACluster gives each worker its CUDA_VISIBLE_DEVICES."""
    import copy
    import os

    from distributed import LocalCluster
    if gpus is None and not os.environ.get("LANTERN_GPU"):
        from ..engine.gpu.devices import egl_devices
        gpus = [d.index for d in egl_devices() if not d.software]
    options = dict(threads_per_worker=1, processes=True, dashboard_address=":0",
                   silence_logs=logging.ERROR, **options)
    if not gpus:
        return LocalCluster(n_workers=workers, resources={"bpy": 1, "gl": 1}, **options)

    class LocalGPUCluster(LocalCluster):
        def new_worker_spec(self):
            (name, spec), = super().new_worker_spec().items()
            spec = copy.deepcopy(spec)
            gpu = gpus[len(self.worker_spec) % len(gpus)]
            spec["options"]["env"] = {**spec["options"].get("env", {}), "LANTERN_GPU": str(gpu)}
            return {name: spec}

    cluster = LocalGPUCluster(n_workers=0, resources={"bpy": 1, "gl": 1, "GPU": 1}, **options)
    cluster.scale(workers)
    return cluster


class DaskRunner:
    def __init__(self, address, local_workers=2):
        from distributed import Client
        logging.getLogger("distributed").setLevel(logging.ERROR)
        self._cluster = None
        try:
            if address == "local":
                self._cluster = local_cluster(local_workers)
                self._client = Client(self._cluster)
                self._client.wait_for_workers(local_workers)
            else:
                self._client = Client(address, timeout="10s")
        except (OSError, TimeoutError) as error:
            if self._cluster is not None:
                self._cluster.close()
            raise FarmError(f"{address}: cannot connect to the Dask scheduler: {error}")
        self.name = self._client.scheduler.address if address != "local" else "LocalCluster"
        self._futures = {}       # future -> (task, time submitted)
        self._scattered = {}     # stage digest -> future of its text
        self._lost = {}          # task key -> [worker addresses that died running it]
        self._client.subscribe_topic("all", self._event)
        self._client.register_plugin(_release_plugin(), name="lantern-release-sessions")

    @property
    def dashboard(self):
        try:
            return self._client.dashboard_link
        except (KeyError, TypeError, AttributeError):
            return None

    def _event(self, event):
        _, message = event
        if isinstance(message, dict) and message.get("action") == "remove-worker" \
                and not message.get("expected"):
            for key in message.get("processing-tasks", ()):
                self._lost.setdefault(key, []).append(message.get("worker", "a worker"))

    def _resources(self):
        info = self._client.scheduler_info(n_workers=-1)
        return [w.get("resources", {}) for w in info.get("workers", {}).values()]

    def workers(self, needs=None):
        return sum(all(r.get(k, 0) >= v for k, v in (needs or {}).items())
                   for r in self._resources())

    def offers(self, needs):
        return self.workers(needs) > 0

    @property
    def pending(self):
        return len(self._futures)

    def submit(self, task, stage_text=None):
        args = [task]
        if stage_text is not None:
            digest = task.stage_digest
            if digest not in self._scattered:
                self._scattered[digest] = self._client.scatter(stage_text, hash=False)
            args.append(self._scattered[digest])
        future = self._client.submit(farm_tasks.run, *args, key=_key(task),
                                     resources=task.needs, pure=False)
        self._futures[future] = (task, time.perf_counter())

    def wait(self, timeout=None):
        from distributed import wait
        if not self._futures:
            return []
        try:
            finished, _ = wait(list(self._futures), timeout=timeout, return_when="FIRST_COMPLETED")
        except TimeoutError:
            return []
        done = []
        for future in finished:
            task, sent = self._futures.pop(future)
            lost = self._lost.pop(future.key, [])
            latency = time.perf_counter() - sent
            if future.status == "finished":
                done.append(Done(task, future.result(), "", lost, latency))
            else:
                error = future.exception() if future.status == "error" else None
                if type(error).__name__ == "KilledWorker":
                    reason = f"its worker died {max(len(lost), 1)} times " \
                             "(the scheduler's allowed-failures)"
                else:
                    reason = f"{type(error).__name__}: {error}" if error else future.status
                done.append(Done(task, None, reason, lost, latency))
            future.release()
        return done

    def fail_pending(self, reason):
        """Gives up the tasks not done (no worker can run them): Done records."""
        done = []
        for future, (task, sent) in list(self._futures.items()):
            future.cancel()
            done.append(Done(task, None, reason, self._lost.pop(future.key, []),
                             time.perf_counter() - sent))
        self._futures.clear()
        return done

    def close(self, interrupted=False):
        try:
            self._client.unsubscribe_topic("all")
            self._client.close(timeout=5)
        finally:
            if self._cluster is not None:
                self._cluster.close(timeout=10)


def open_runner(scheduler, local_processes, render=False):
    """`scheduler`: None for the local pool, 'local' for an embedded LocalCluster,
    or a Dask scheduler address."""
    if scheduler is None:
        return PoolRunner(local_processes, render)
    return DaskRunner(scheduler, local_processes)
