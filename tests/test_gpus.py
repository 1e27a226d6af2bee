"""Which GPU the engine draws on, what a software rasteriser means, and frames too large
for the device (engine/gpu/devices.py, engine/gpu/budget.py), on this machine's one EGL
device, llvmpipe:

- `--gpu 0` renders and names the device, `--gpu 1` is exit 2 naming the one device
  there is, `--gpu list` prints it;
- `-j 2` on one device: both workers draw on device 0, and the summary says so;
- the software warning comes once per process; LANTERN_REQUIRE_GPU=1, or `--gpu`
  without the suite's LANTERN_REQUIRE_GPU=0, stops with exit 1 and one line;
- a 16384x16384 frame at ultra is refused before any drawing, with its size;
- a Dask LocalCluster whose two workers have GPU=1 and LANTERN_GPU 0 and 1 (device 1
  stands for device 0 here: tests/_gpu_alias.py): each chunk names its worker's
  device, and a worker without a GPU gets none.
"""
import os
import pathlib
import subprocess
import sys

import pytest

from test_cold_start import CUBE

HERE = pathlib.Path(__file__).resolve().parent
WARNING = "warning: rendering on the CPU (llvmpipe): no GPU device"


def lantern(*args, env=None, **kw):
    return subprocess.run([sys.executable, "-m", "lantern", *map(str, args)],
                          capture_output=True, text=True, env=env, **kw)


def without_cpu_expected(**extra):
    """The environment of a machine that does not say it expects the CPU (the suite's
    conftest does)."""
    env = {k: v for k, v in os.environ.items() if k not in ("LANTERN_REQUIRE_GPU", "LANTERN_GPU")}
    return {**env, **extra}


@pytest.fixture
def cube(tmp_path):
    path = tmp_path / "cube.usda"
    path.write_text(CUBE)
    return path


def test_gpu_list_prints_the_device():
    proc = lantern("render", "--gpu", "list")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0].startswith("0 = llvmpipe"), proc.stdout
    assert "software" in proc.stdout


def test_gpu_0_renders_and_says_so(cube, tmp_path):
    out = tmp_path / "cube.exr"
    proc = lantern("render", cube, "-o", out, "--size", "32x18", "--gpu", "0", "--debug")
    assert proc.returncode == 0, proc.stderr
    assert out.is_file()
    assert "on EGL device 0 of 1" in proc.stdout
    assert "free of" in proc.stdout       # the device's memory, as its driver (here: host) says
    assert proc.stderr == ""              # the suite expects the CPU: no warning


@pytest.mark.parametrize("how", ["option", "environment"])
def test_a_device_that_does_not_exist_is_a_usage_error_naming_the_devices(cube, tmp_path, how):
    out = tmp_path / "cube.exr"
    if how == "option":
        proc = lantern("render", cube, "-o", out, "--gpu", "1")
    else:
        proc = lantern("render", cube, "-o", out, env=dict(os.environ, LANTERN_GPU="1"))
    assert proc.returncode == 2
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert "no such GPU" in lines[0] and "1 EGL device: 0 = llvmpipe" in lines[0]
    assert not out.exists()


def test_the_software_warning_comes_once_per_process(cube, tmp_path):
    other = tmp_path / "other.usda"
    other.write_text(CUBE)
    proc = lantern("render", cube, other, "-o", tmp_path / "out/", "--size", "32x18",
                   env=without_cpu_expected())
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.splitlines() == [WARNING]


@pytest.mark.parametrize("how", ["LANTERN_REQUIRE_GPU=1", "--gpu 0"])
def test_a_software_rasteriser_stops_a_render_that_expects_a_gpu(cube, tmp_path, how):
    out = tmp_path / "cube.exr"
    if how == "--gpu 0":
        proc = lantern("render", cube, "-o", out, "--size", "32x18", "--gpu", "0",
                       env=without_cpu_expected())
    else:
        proc = lantern("render", cube, "-o", out, "--size", "32x18",
                       env=without_cpu_expected(LANTERN_REQUIRE_GPU="1"))
    assert proc.returncode == 1
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and "rendering on the CPU (llvmpipe)" in lines[0], proc.stderr
    assert how.split("=")[0].split(" ")[0] in lines[0]
    assert not out.exists()


def _worker_rows(stdout):
    """{worker: device} from a sequence's summary table."""
    rows = {}
    for line in stdout.splitlines():
        cells = [c.strip() for c in line.strip().strip("│").split("│")]
        if len(cells) >= 7 and (cells[0].startswith("local pid") or "://" in cells[0]):
            rows[cells[0]] = cells[1]
    return rows


def test_two_local_workers_on_one_device_both_draw_on_it(cube, tmp_path):
    proc = lantern("render", cube, "-o", tmp_path / "f_####.exr", "--frames", "1:4",
                   "--size", "32x18", "-j", "2", env=without_cpu_expected(COLUMNS="1000"))
    assert proc.returncode == 0, proc.stderr
    rows = _worker_rows(proc.stdout)
    assert len(rows) == 2, proc.stdout
    assert all(d.startswith("EGL device 0: llvmpipe") for d in rows.values()), rows
    # Each worker warned once; the client says it once.
    assert proc.stderr.count(WARNING) == 1, proc.stderr


def test_workers_spread_over_the_hardware_devices():
    from lantern.engine.gpu.devices import Device, spread
    node = [Device(0, False), Device(1, False), Device(2, False), Device(3, True)]
    assert [spread(k, node) for k in range(6)] == [0, 1, 2, 0, 1, 2]   # never the CPU
    assert [spread(k, [Device(0, True)]) for k in range(3)] == [0, 0, 0]


def test_a_frame_too_large_for_the_device_is_refused_before_any_drawing(cube, tmp_path,
                                                                      monkeypatch):
    from lantern.engine import RenderSettings, Session
    from lantern.engine.gpu.budget import TooLarge
    from lantern.engine.gpu.framegraph import FrameGraph
    from lantern.engine.usd.opening import open_stage

    with Session(open_stage(str(cube)), RenderSettings(width=32, height=18)) as session:
        first = session.render()
        assert first.stats["gpu_device"] == 0 and first.stats["gpu_memory_free"] > 0
        assert first.stats["gpu_memory_source"].startswith("host memory")
        assert first.stats["target_bytes_allocated"] > 0
        assert session.render().stats["target_bytes_allocated"] == 0   # the pool's again

        def drew(self, frame):
            raise AssertionError("the frame graph ran")
        monkeypatch.setattr(FrameGraph, "run", drew)
        session.configure(width=16384, height=16384, preset="ultra")
        with pytest.raises(TooLarge, match="16384x16384 at ultra .* drawn at 49152x49152"):
            session.render()
        monkeypatch.undo()
        session.configure(width=32, height=18, preset="medium")
        assert session.render().rgba.shape == (18, 32, 4)     # the session goes on

    out = tmp_path / "big.exr"
    proc = lantern("render", cube, "-o", out, "--size", "16384x16384", "--preset", "ultra")
    assert proc.returncode == 1
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and "49152x49152" in lines[0], proc.stderr
    assert "largest render target (16384x16384)" in lines[0]
    assert not out.exists()


@pytest.mark.parametrize("preset, passes", [("medium", ()), ("high", ("Depth", "AO", "DiffDir")),
                                            ("ultra", ())])
def test_the_targets_estimate_is_what_the_pool_makes_less_scratch(cube, preset, passes):
    """The bytes a frame's targets need, from the frame graph's TARGETS (at the drawn
    size, and at the image size after supersampling's reduction), against what the
    pool holds after the frame: a lower bound (passes' own scratch targets are not in
    TARGETS), and close to it."""
    from lantern.engine import RenderSettings, Session
    from lantern.engine.gpu.context import run_gl
    from lantern.engine.gpu.resources import TEXEL_BYTES
    from lantern.engine.usd.opening import open_stage
    settings = RenderSettings(width=64, height=36, preset=preset, passes=frozenset(passes))
    with Session(open_stage(str(cube)), settings) as session:
        estimate = session.render().stats["target_bytes_allocated"]
        pool = session._renderer.pool
        made = run_gl(lambda gl: sum(w * h * TEXEL_BYTES[fmt] * len(objects)
                                     for ((w, h), fmt), objects in pool._free.items()
                                     if w % 64 == 0 and h % 36 == 0 and w // 64 <= 3))
    assert 0.8 * made <= estimate <= made, (estimate, made)


def test_targets_past_the_free_memory_are_refused_with_their_size():
    from lantern.engine.gpu.budget import Memory, TooLarge, check
    free = Memory(total=8 << 30, free=1 << 30, source="GL_NVX_gpu_memory_info")
    check((1920, 1080), 2, "high", 16384, 1920 * 1080 * 4 * 80, free)
    with pytest.raises(TooLarge, match=r"8192x8192: its render targets need 5\.0 GiB, and "
                                       r"the GPU has 1\.0 GiB free \(GL_NVX_gpu_memory_info\)"):
        check((8192, 8192), 1, "medium", 16384, 8192 * 8192 * 80, free)
    check((8192, 8192), 1, "medium", 16384, 8192 * 8192 * 80, Memory())   # nothing known


@pytest.fixture
def gpu_cluster():
    """A LocalCluster of two workers with GPU=1 and LANTERN_GPU 0 and 1 (farm/'s own, as
    `--scheduler local` makes on a node with two GPUs), and a third worker with GL but
    no GPU."""
    from distributed import Client

    from lantern.farm.runners import local_cluster
    cluster = local_cluster(2, gpus=[0, 1], preload=[str(HERE / "_gpu_alias.py")])
    plain = None
    try:
        client = Client(cluster)
        client.wait_for_workers(2, timeout=120)
        plain = subprocess.Popen([sys.executable, "-m", "dask", "worker", cluster.scheduler_address,
                                  "--nthreads", "1", "--no-nanny", "--resources", "gl=1",
                                  "--name", "no-gpu", "--lifetime", "300s"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        client.wait_for_workers(3, timeout=120)
        gpus = client.run(lambda: os.environ.get("LANTERN_GPU"))
        yield cluster.scheduler_address, gpus
        client.close()
    finally:
        if plain is not None:
            plain.terminate()
            plain.wait(30)
        cluster.close()


def test_dask_workers_draw_on_their_own_gpus(gpu_cluster, cube, tmp_path):
    address, gpus = gpu_cluster
    assert sorted(v for v in gpus.values() if v is not None) == ["0", "1"]
    proc = lantern("render", cube, "-o", tmp_path / "f_####.exr", "--frames", "1:4",
                   "--size", "32x18", "--scheduler", address,
                   env=dict(os.environ, COLUMNS="1000"), timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    rows = _worker_rows(proc.stdout)
    assert set(rows) == {w for w, gpu in gpus.items() if gpu is not None}, proc.stdout
    for worker, device in rows.items():
        assert device.startswith(f"EGL device {gpus[worker]}: llvmpipe"), (worker, device)


@pytest.fixture
def addon():
    import lantern
    lantern.register()
    yield
    lantern.unregister()


def test_the_engine_host_says_it_once_to_blender(addon, tmp_path, monkeypatch):
    """F12 in Blender: the engine host's warm-up renders (engine/host/warmup.py) do not
    swallow the warning; the first frame Blender gets carries it, the next does not.
    (With the suite's LANTERN_REQUIRE_GPU=0 no frame does: tests/test_prestart.py.)"""
    import bpy
    from lantern.addon import host, scene_render
    monkeypatch.delenv("LANTERN_REQUIRE_GPU")   # the host inherits Blender's environment
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    scene.render.engine = 'LANTERN'
    scene.render.resolution_x, scene.render.resolution_y = 32, 18
    scene.render.resolution_percentage = 100
    blend = tmp_path / "default.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    scene_render.shutdown()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(blend))     # starts the host and its warm-up
        name = f"render:{bpy.context.scene.name_full}:{bpy.context.view_layer.name}"
        seen = []
        for _ in range(2):
            bpy.ops.render.render()
            seen.append(host.get().channels[name].latest.warnings)
    finally:
        scene_render.shutdown()      # the next host starts with the suite's environment
    cpu = WARNING.removeprefix("warning: ")
    assert seen == [[cpu], []], seen
