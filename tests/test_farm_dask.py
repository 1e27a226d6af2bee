"""farm/ on a real Dask cluster: a `dask scheduler` and two `dask worker`s on 127.0.0.1,
started here as subprocesses (free ports, bounded lifetimes, always torn down). One
worker offers bpy and gl, the other gl only.

- a sequence rendered on the cluster equals today's one-process render, also when the
  outputs come back to the client (--collect);
- a batch export of ten files (a truncated and a missing .blend among them) gives the
  local batch's summary and outputs, and the gl-only worker never gets an export;
- a worker killed mid-chunk: its chunk runs on the other, every frame is written once
  (the frames it had written are kept), no temporary file is left, the summary says so.
"""
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

import pytest

from test_farm import (_snapshot, assert_same_frames, lantern, read_frames,
                       reference_frames, skinned_scene)

LIFETIME = "300s"  # every process of the cluster ends by itself after this


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args, log):
    return subprocess.Popen([sys.executable, "-m", "dask", *args], stdout=log,
                            stderr=subprocess.STDOUT)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    from distributed import Client
    logs = tmp_path_factory.mktemp("dask-logs")
    port, dashboard = _free_port(), _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = {}
    try:
        procs["scheduler"] = _dask("scheduler", "--host", "127.0.0.1", "--port", str(port),
                                   "--dashboard-address", f"127.0.0.1:{dashboard}",
                                   "--idle-timeout", LIFETIME,
                                   log=open(logs / "scheduler.log", "w"))
        # Two threads on the full worker: two exports at once, like the local -j 2; its
        # gl=1 still runs one render chunk at a time.
        for name, threads, resources in (("full", "2", "bpy=2,gl=1"), ("gl-only", "1", "gl=1")):
            procs[name] = _dask("worker", address, "--host", "127.0.0.1", "--name", name,
                                "--nthreads", threads, "--no-nanny", "--resources", resources,
                                "--lifetime", LIFETIME, "--death-timeout", "30",
                                log=open(logs / f"{name}.log", "w"))
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=60)
            names = {w["name"]: a for a, w in client.scheduler_info()["workers"].items()}
        yield {"address": address, "procs": procs, "workers": names, "logs": logs,
               "dashboard": dashboard}
    finally:
        # Workers first, then the scheduler: each closes on SIGTERM, else it is killed.
        for name in sorted(procs, key=lambda n: n == "scheduler"):
            proc = procs[name]
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return skinned_scene(tmp_path_factory.mktemp("farm-dask") / "rig.usda")


def test_a_sequence_on_the_cluster_equals_a_local_render(cluster, scene, tmp_path):
    shared, collected = tmp_path / "shared", tmp_path / "collected"
    for out, extra in ((shared, []), (collected, ["--collect"])):
        proc = lantern("render", scene, "-o", out / "f_####.exr", "--frames", "1:24",
                       "--size", "64x36", "--scheduler", cluster["address"], *extra)
        assert proc.returncode == 0, proc.stderr
        assert sorted(os.listdir(out)) == [f"f_{f:04d}.exr" for f in range(1, 25)]
        assert "24 frames written, 0 failed" in proc.stdout
        assert f"dashboard: http://127.0.0.1:{cluster['dashboard']}/status" in proc.stdout
        assert cluster["workers"]["full"] in proc.stdout or \
            cluster["workers"]["gl-only"] in proc.stdout
    want = reference_frames(scene, 1, 24)
    assert_same_frames(read_frames(shared, range(1, 25)), want)
    assert_same_frames(read_frames(collected, range(1, 25)), want)
    # LANTERN_SCHEDULER is the same as --scheduler.
    proc = lantern("render", scene, "-o", tmp_path / "env" / "f_####.exr", "--frames", "1:2",
                   "--size", "32x18", env=dict(os.environ, LANTERN_SCHEDULER=cluster["address"]))
    assert proc.returncode == 0 and cluster["address"] in proc.stdout, proc.stdout + proc.stderr


WIDE = dict(os.environ, COLUMNS="1000")  # the summary table unfolded, one line a row


def _rows(stdout):
    """{file: (status, warnings, worker, tries, output or reason)} from the summary table."""
    rows = {}
    for line in stdout.splitlines():
        cells = [c.strip() for c in line.strip().strip("│").split("│")]
        if len(cells) == 7 and cells[0]:
            rows[cells[0]] = (cells[1], cells[3], cells[4], cells[5], cells[6])
    return rows


def test_ten_exports_on_the_cluster_match_a_local_batch(cluster, corpus, tmp_path):
    blender = corpus / "blender"
    good = ["01_cube", "01_morphed_cube", "01_two_sided_plane", "01_alpha_mask",
            "02_shared_mesh", "02_node_hierarchy", "03_animated_cube", "03_skinned_cylinder"]
    blends = [blender / f"{name}.blend" for name in good]
    truncated = tmp_path / "truncated.blend"
    truncated.write_bytes((blender / "01_cube.blend").read_bytes()[:3000])
    blends += [truncated, tmp_path / "missing.blend"]
    runs = {}
    for where, extra in (("local", ["-j", "2"]), ("farm", ["--scheduler", cluster["address"]])):
        out = tmp_path / where
        proc = lantern("export", *blends, "-o", out, "--format", "usda", *extra, env=WIDE)
        assert proc.returncode == 1, proc.stdout + proc.stderr  # two files failed
        assert proc.stdout.strip().splitlines()[-1] == "8 exported, 2 failed"
        runs[where] = (_rows(proc.stdout), out)
    (local, local_out), (farm, farm_out) = runs["local"], runs["farm"]
    assert sorted(local) == sorted(farm) == sorted(b.name for b in blends)
    for name in local:
        status, warnings, _, tries, detail = local[name]
        f_status, f_warnings, f_worker, f_tries, f_detail = farm[name]
        assert (f_status, f_warnings, f_tries) == (status, warnings, tries), name
        if status == "failed":
            assert f_detail == detail, name
        else:
            assert f_detail == detail.replace(str(local_out), str(farm_out)), name
        # The worker without bpy never gets an export.
        assert f_worker == cluster["workers"]["full"], (name, f_worker)
    assert "missing.blend: no such file" in local["missing.blend"][4]
    assert "truncated.blend" in local["truncated.blend"][4]
    assert sorted(os.listdir(local_out)) == sorted(os.listdir(farm_out)) == \
        sorted(f"{name}.usda" for name in good)
    for name in os.listdir(local_out):
        assert (local_out / name).read_text() == (farm_out / name).read_text(), name
    # Again with --resume: the eight outputs are newer than their inputs.
    proc = lantern("export", *blends, "-o", farm_out, "--format", "usda", "--resume",
                   "--scheduler", cluster["address"])
    assert proc.stdout.strip().splitlines()[-1] == "0 exported, 2 failed, 8 skipped (up to date)"


def _tree(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def test_collected_exports_come_back_with_their_textures(cluster, corpus, tmp_path):
    """--collect: the worker exports into its own temporary folder and sends the layer
    and its copied textures; this process writes them where a local export would."""
    blend = corpus / "blender" / "01_principled_material.blend"
    local = lantern("export", blend, "-o", tmp_path / "local" / "01_principled_material.usda",
                    "--textures", "copy")
    assert local.returncode == 0, local.stderr
    farm = lantern("export", blend, "-o", tmp_path / "farm", "--format", "usda", "--textures",
                   "copy", "--collect", "--scheduler", cluster["address"])
    assert farm.returncode == 0, farm.stdout + farm.stderr
    want, got = _tree(tmp_path / "local"), _tree(tmp_path / "farm")
    assert any(name.startswith("01_principled_material_textures/") for name in want), sorted(want)
    assert got == want


def test_a_killed_worker_has_its_chunk_retried_and_no_frame_doubled(cluster, scene, tmp_path):
    """Runs last: it leaves the cluster one worker short."""
    from distributed import Client
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "lantern", "render", str(scene), "-o",
                             str(out / "f_####.exr"), "--frames", "1:24", "--size", "320x180",
                             "--chunk", "12", "--scheduler", cluster["address"]],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        with Client(cluster["address"], timeout="30s") as client:
            victim, deadline = None, time.monotonic() + 120
            while victim is None and time.monotonic() < deadline and proc.poll() is None:
                for worker, keys in client.processing().items():
                    for key in map(str, keys):
                        if not key.startswith("lantern-render-frames-"):
                            continue
                        first, last = map(int, key.split("-")[3:5])
                        names = [f"f_{f:04d}.exr" for f in range(first, last + 1)]
                        if out.is_dir() and any(n in os.listdir(out) for n in names):
                            victim = worker  # it has written frames of the chunk it runs
                time.sleep(0.005)
            assert victim is not None, "no chunk was seen running"
            before = _snapshot(out)
            name = next(n for n, a in cluster["workers"].items() if a == victim)
            cluster["procs"][name].send_signal(signal.SIGKILL)
        stdout, stderr = proc.communicate(timeout=180)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, stderr
    assert sorted(os.listdir(out)) == [f"f_{f:04d}.exr" for f in range(1, 25)], \
        "a frame is missing or a partial file was left"
    after = _snapshot(out)
    assert all(after[n] == before[n] for n in before), "a frame was written twice"
    assert f"its worker died while running it ({victim})" in stdout, stdout
    assert "24 frames written, 0 failed" in stdout
    assert_same_frames(read_frames(out, range(1, 25)), reference_frames(scene, 1, 24, (320, 180)))
    shutil.rmtree(out)
