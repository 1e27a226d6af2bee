"""Sequences and batch exports on farm/: frames per second, time to the first frame and
the per-frame cost against a warm Session render, for

- one local process, today's path before farm/ (render_sequence, one Session, each frame
  written as it comes);
- the local process pool with 1 and 2 processes (the default mode is one of them);
- an embedded Dask LocalCluster (`--scheduler local`, 2 workers);
- two Dask workers on a `dask scheduler` (started here, on 127.0.0.1): their first run
  (cold workers) and a second run (the workers kept their Sessions);

and a batch export of six .blend files on the pool and on a LocalCluster. Every figure
is wall time of the whole command (process start to exit) as a user sees it; each mode
runs ROUNDS times, interleaved, and the best run is kept (the machine is shared).
Prints a table; asserts nothing.
"""
import os
import pathlib
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

FRAMES = 96
SIZE = "320x180"
ROUNDS = 3
BLOCK = 8     # frames per interleaved block of the in-process comparison
CORPUS = HERE.parent.parent / "shared" / "corpus" / "blender"
EXPORTS = ["01_cube", "01_morphed_cube", "02_shared_mesh", "03_animated_cube",
           "03_skinned_cylinder", "01_two_sided_plane"]

TODAY = """
import os, sys
from pxr import Usd
from lantern.engine import RenderSettings
from lantern.engine.api import render_sequence
from lantern.engine.image_io import write_image
scene, out, frames, w, h = sys.argv[1:6]
os.makedirs(os.path.dirname(out), exist_ok=True)
stage = Usd.Stage.Open(scene)
for frame, result in render_sequence(stage, 1, int(frames), RenderSettings(width=int(w), height=int(h))):
    write_image(out.replace("####", f"{int(frame):04d}"), result.rgba)
"""


def build_scene(folder):
    import lantern.exporters  # noqa: F401  (Blender's pxr first: test_farm imports pxr)
    from test_farm import skinned_scene
    return skinned_scene(folder / "rig.usda", frames=FRAMES, joints=32, grid=200)


def per_frame_in_process(scene, out):
    """Seconds per warm frame in this process (no process start, no transport), all on
    one Session (the farm cache's), interleaved block by block of BLOCK frames so the
    machine's load drifts alike for every mode; the median block of each is kept:
    a warm render alone; the same plus writing the EXR (today's loop); farm chunk
    tasks of BLOCK frames and of 1 frame (tasks.run: cache look-up, bookkeeping, write).
    Also the CPU time (every thread) of a warm render."""
    from dataclasses import replace

    from lantern.engine.image_io import write_image
    from lantern.farm import sessions, tasks
    w, h = map(int, SIZE.split("x"))
    os.makedirs(out, exist_ok=True)
    pattern = str(out / "f_####.exr")
    base = tasks.RenderChunk(scene=str(scene), frames=(1.0,), pattern=pattern, width=w, height=h)
    tasks.run(base)  # loads the stage into the cache: the cold frame, left out
    session, _ = sessions.session_for(base)

    def loop(frames, write):
        for frame in frames:
            result = session.render(frame=frame)
            if write:
                write_image(pattern.replace("####", f"{int(frame):04d}"), result.rgba)

    modes = {
        "warm Session render": lambda frames: loop(frames, False),
        "render + write EXR (today's loop)": lambda frames: loop(frames, True),
        f"farm chunks of {BLOCK} frames": lambda frames: tasks.run(replace(base, frames=frames)),
        "farm chunks of 1 frame":
            lambda frames: [tasks.run(replace(base, frames=(f,))) for f in frames],
    }
    seconds = {name: [] for name in modes}
    warm_cpu = []
    for first in range(2, FRAMES + 1 - BLOCK, BLOCK):
        frames = tuple(float(f) for f in range(first, first + BLOCK))
        for name, run_block in modes.items():
            start, cpu = time.perf_counter(), time.process_time()
            run_block(frames)
            seconds[name].append((time.perf_counter() - start) / BLOCK)
            if name == "warm Session render":
                warm_cpu.append((time.process_time() - cpu) / BLOCK)
    sessions.release_all()
    return {name: statistics.median(v) for name, v in seconds.items()}, statistics.median(warm_cpu)


def cpu_seconds(pids):
    """CPU seconds (user + system, every thread) of this process's reaped children and
    of the processes `pids` (the external Dask workers and scheduler)."""
    import resource

    import psutil
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = usage.ru_utime + usage.ru_stime
    for pid in pids:
        times = psutil.Process(pid).cpu_times()
        total += times.user + times.system
    return total


def timed(command, out_folder, pids=()):
    """(wall seconds, seconds to the first file in out_folder, CPU seconds of every
    process involved) of a command."""
    shutil.rmtree(out_folder, ignore_errors=True)
    first, stop = [None], threading.Event()
    cpu = cpu_seconds(pids)
    start = time.perf_counter()

    def watch():
        while not stop.is_set():
            try:
                if any(not n.startswith(".") for n in os.listdir(out_folder)):
                    first[0] = time.perf_counter() - start
                    return
            except OSError:
                pass
            time.sleep(0.002)
    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    proc = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - start
    cpu = cpu_seconds(pids) - cpu
    stop.set()
    watcher.join()
    if proc.returncode != 0:
        raise RuntimeError(f"{command[:6]}... failed:\n{proc.stdout}\n{proc.stderr}")
    return wall, first[0] if first[0] is not None else wall, cpu


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_cluster(log_folder):
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    log = open(log_folder / "dask.log", "w")
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--dashboard-address", f"127.0.0.1:{free_port()}",
                               "--idle-timeout", "600s"], stdout=log, stderr=log)]
    for name in ("a", "b"):
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "worker", address, "--host", "127.0.0.1", "--name",
             name, "--nthreads", "1", "--no-nanny", "--resources", "gl=1",
             "--lifetime", "600s"], stdout=log, stderr=log))
    from distributed import Client
    with Client(address, timeout="60s") as client:
        client.wait_for_workers(2, timeout=60)
    return address, procs


def stop_cluster(procs):
    for proc in reversed(procs):
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()


def main():
    folder = pathlib.Path(tempfile.mkdtemp(prefix="lantern-bench-farm-"))
    try:
        run(folder)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def run(folder):
    scene = build_scene(folder)
    out = folder / "out"
    pattern = str(out / "f_####.exr")
    lantern = [sys.executable, "-m", "lantern", "render", str(scene), "-o", pattern,
               "--frames", f"1:{FRAMES}", "--size", SIZE]
    w, h = SIZE.split("x")
    address, cluster = start_cluster(folder)
    try:
        modes = {
            "one local process (today's path)":
                [sys.executable, "-c", TODAY, str(scene), pattern, str(FRAMES), w, h],
            "pool, 1 process (default, -j 1)": lantern,
            "pool, 2 processes (-j 2)": lantern + ["-j", "2"],
            "Dask LocalCluster, 2 workers": lantern + ["--scheduler", "local"],
            "two Dask workers, first run": lantern + ["--scheduler", address],
            "two Dask workers, warm": lantern + ["--scheduler", address],
        }
        best = {}
        for _ in range(ROUNDS):
            for name, command in modes.items():
                if name == "two Dask workers, first run" and name in best:
                    continue  # only once: the workers are warm after it
                pids = [p.pid for p in cluster] if address in command else ()
                wall, first, cpu = timed(command, out, pids)
                if name not in best or wall < best[name][0]:
                    best[name] = (wall, first, cpu)
        in_process, warm_cpu = per_frame_in_process(scene, folder / "in-process")
        warm = in_process["warm Session render"]

        exports = [str(CORPUS / f"{name}.blend") for name in EXPORTS]
        export_modes = {
            "pool, -j 2": ["-j", "2"],
            "Dask LocalCluster, 2 workers": ["--scheduler", "local"],
        }
        export_best = {}
        for _ in range(ROUNDS):
            for name, extra in export_modes.items():
                wall, _, _ = timed([sys.executable, "-m", "lantern", "export", *exports, "-o",
                                 str(folder / "exported"), *extra], folder / "exported")
                export_best[name] = min(wall, export_best.get(name, wall))
    finally:
        stop_cluster(cluster)

    today = best["one local process (today's path)"]
    today_per_frame = (today[0] - today[1]) / (FRAMES - 1)
    print(f"{FRAMES}-frame skinned sequence at {SIZE} (32 joints, 800-point rig, ground, "
          f"shadowed sun); best of {ROUNDS}")
    print("per warm frame, in one process (no transport, no process start):")
    for name, seconds in in_process.items():
        print(f"  {name:36} {seconds * 1000:6.1f} ms  {seconds / warm - 1:+5.0%} vs warm render")
    print(f"  CPU time of a warm Session render (every thread): {warm_cpu * 1000:.1f} ms")
    print("end to end, the whole command (wall time per frame after the first frame; CPU "
          "time of every process, start-up included, per frame):")
    print(f"{'mode':36} {'frames/s':>9} {'wall s':>7} {'first frame s':>14} "
          f"{'ms/frame after':>15} {'vs warm':>8} {'vs today':>9} {'CPU ms/frame':>13} "
          f"{'vs today':>9}")
    for name, (wall, first, cpu) in best.items():
        per_frame = (wall - first) / (FRAMES - 1)
        print(f"{name:36} {FRAMES / wall:9.1f} {wall:7.2f} {first:14.2f} "
              f"{per_frame * 1000:15.1f} {per_frame / warm - 1:+8.0%} "
              f"{per_frame / today_per_frame - 1:+9.0%} {cpu / FRAMES * 1000:13.1f} "
              f"{cpu / today[2] - 1:+9.0%}")
    print(f"\nbatch export of {len(EXPORTS)} .blend files (a Blender process each)")
    for name, wall in export_best.items():
        print(f"{name:36} {wall:7.2f} s")


if __name__ == "__main__":
    main()
