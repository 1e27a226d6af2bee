"""farm/ on this machine: sequences as chunks on local worker processes that keep their
Session, chunk sizes from measured costs, the worker-local session cache, a dead
worker's chunk run again, --resume, and the command line's checks.
(tests/test_farm_dask.py runs the same tasks on a real Dask scheduler and workers.)"""
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np
import psutil
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdSkel, Vt

from lantern.farm import chunking

SIZE = (64, 36)


def skinned_scene(path, frames=24, joints=8, grid=16):
    """A Z-up rig swaying over `frames` frames (a chain of joints with an animated
    rotation each, a grid mesh bound with 2 influences), a static ground, a camera and
    a shadow-casting sun: every frame differs. Written to `path` (the workers read it)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(frames)
    stage.SetFramesPerSecond(24)
    root = UsdSkel.Root.Define(stage, "/root")
    skel = UsdSkel.Skeleton.Define(stage, "/root/skel")
    names = ["j0"]
    for i in range(1, joints):
        names.append(f"{names[-1]}/j{i}")
    step = 4.0 / joints
    skel.CreateJointsAttr(names)
    world = [Gf.Matrix4d().SetTranslate(Gf.Vec3d(step * i, 0, 0.3)) for i in range(joints)]
    local = [world[0]] + [Gf.Matrix4d().SetTranslate(Gf.Vec3d(step, 0, 0))] * (joints - 1)
    skel.CreateBindTransformsAttr(world)
    skel.CreateRestTransformsAttr(local)
    anim = UsdSkel.Animation.Define(stage, "/root/skel/anim")
    anim.CreateJointsAttr(names)
    anim.CreateTranslationsAttr([Gf.Vec3f(0, 0, 0.3)] + [Gf.Vec3f(step, 0, 0)] * (joints - 1))
    anim.CreateScalesAttr([Gf.Vec3h(1, 1, 1)] * joints)
    rotations = anim.CreateRotationsAttr()
    for t in range(1, frames + 1):
        a = 0.12 * np.sin(2 * np.pi * t / frames)
        q = Gf.Quatf(float(np.cos(a / 2)), Gf.Vec3f(0, float(np.sin(a / 2)), 0))
        rotations.Set([q] * joints, t)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    UsdSkel.BindingAPI.Apply(root.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])

    xs, ys = np.meshgrid(np.linspace(0, 4, grid), np.linspace(-0.4, 0.4, 4))
    points = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 0.3)], 1).astype(np.float32)
    r, c = np.meshgrid(np.arange(3), np.arange(grid - 1), indexing="ij")
    a = (r * grid + c).ravel()
    quads = np.stack([a, a + 1, a + grid + 1, a + grid], 1)
    mesh = UsdGeom.Mesh.Define(stage, "/root/mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr([4] * len(quads))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.ravel().astype(np.int32)))
    mesh.CreateDoubleSidedAttr(True)
    joint = np.clip((points[:, 0] / step).astype(np.int32), 0, joints - 1)
    indices = np.stack([joint, np.clip(joint + 1, 0, joints - 1)], 1)
    weights = np.tile(np.float32([0.7, 0.3]), (len(points), 1))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateJointIndicesPrimvar(False, 2).Set(Vt.IntArray.FromNumpy(indices.ravel()))
    binding.CreateJointWeightsPrimvar(False, 2).Set(Vt.FloatArray.FromNumpy(weights.ravel()))

    ground = UsdGeom.Mesh.Define(stage, "/ground")
    ground.CreateSubdivisionSchemeAttr("none")
    ground.CreatePointsAttr([(-3, -3, 0), (7, -3, 0), (7, 3, 0), (-3, 3, 0)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    camera = UsdGeom.Camera.Define(stage, "/camera")
    camera.AddTransformOp().Set(Gf.Matrix4d().SetLookAt(
        Gf.Vec3d(2, -18, 8), Gf.Vec3d(2, 0, 0.5), Gf.Vec3d(0, 0, 1)).GetInverse())
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(3.0)
    UsdLux.ShadowAPI.Apply(sun.GetPrim()).CreateShadowEnableAttr(True)
    UsdGeom.Xformable(sun).AddRotateXYZOp().Set(Gf.Vec3f(40, 10, 0))
    stage.Save()
    return path


def lantern(*args, **kwargs):
    return subprocess.run([sys.executable, "-m", "lantern", *map(str, args)],
                          capture_output=True, text=True, timeout=240, **kwargs)


def reference_frames(scene, first, last, size=SIZE):
    """Today's path: one Session in this process, frame after frame."""
    from lantern.engine import RenderSettings
    from lantern.engine.api import render_sequence
    stage = Usd.Stage.Open(str(scene))
    return {int(f): r.rgba for f, r in render_sequence(
        stage, first, last, RenderSettings(width=size[0], height=size[1]))}


def read_frames(folder, frames, pattern="f_{:04d}.exr"):
    from lantern.engine.image_io import read_exr
    return {f: read_exr(str(folder / pattern.format(f))) for f in frames}


def assert_same_frames(got, want):
    assert sorted(got) == sorted(want)
    for frame in want:
        assert np.abs(got[frame] - want[frame]).max() <= 1e-6, frame
    assert np.abs(want[min(want)] - want[max(want) // 2]).max() > 0.01, "the rig must move"


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return skinned_scene(tmp_path_factory.mktemp("farm") / "rig.usda")


def test_sequence_on_local_workers_equals_one_session(scene, tmp_path):
    """The default: chunks on two local processes give today's frames, each written
    once under its own name and nothing else in the folder."""
    proc = lantern("render", scene, "-o", tmp_path / "f_####.exr", "--frames", "1:12",
                   "--size", "64x36", "-j", "2")
    assert proc.returncode == 0, proc.stderr
    assert sorted(os.listdir(tmp_path)) == [f"f_{f:04d}.exr" for f in range(1, 13)]
    assert "12 frames written, 0 failed" in proc.stdout
    assert "local pid" in proc.stdout  # the summary table names the workers
    assert_same_frames(read_frames(tmp_path, range(1, 13)), reference_frames(scene, 1, 12))


def test_a_blend_sequence_ships_its_exported_stage(corpus, tmp_path):
    """A .blend is exported once, here, and its stage reaches the workers as text: the
    frames equal single-frame renders of the same .blend."""
    import imageio.v3 as iio
    blend = corpus / "blender" / "03_skinned_cylinder.blend"
    # Frames 1, 5 and 9 in chunks of 2: the rig barely moves from 1 to 3 (less than an
    # 8-bit step at this size), clearly by 5.
    proc = lantern("render", blend, "-o", tmp_path / "f_####.png", "--frames", "1:9:4",
                   "--size", "48x27", "--chunk", "2")
    assert proc.returncode == 0, proc.stderr
    single = lantern("render", blend, "-o", tmp_path / "single.png", "--frame", "5",
                     "--size", "48x27")
    assert single.returncode == 0, single.stderr
    assert np.array_equal(iio.imread(tmp_path / "f_0005.png"), iio.imread(tmp_path / "single.png"))
    assert not np.array_equal(iio.imread(tmp_path / "f_0001.png"), iio.imread(tmp_path / "f_0005.png"))


def test_sequence_frames_carry_the_view_transform(scene, tmp_path):
    """--view/--look reach the workers: a frame of an AgX sequence is the PNG a single
    AgX render writes, and differs from the Standard one."""
    import imageio.v3 as iio
    common = ["--size", "48x27", "--view", "AgX", "--look", "Punchy"]
    proc = lantern("render", scene, "-o", tmp_path / "f_####.png", "--frames", "2:3", *common)
    assert proc.returncode == 0, proc.stderr
    single = lantern("render", scene, "-o", tmp_path / "agx.png", "--frame", "3", *common)
    standard = lantern("render", scene, "-o", tmp_path / "std.png", "--frame", "3",
                       "--size", "48x27")
    assert single.returncode == 0 and standard.returncode == 0, single.stderr + standard.stderr
    frame = iio.imread(tmp_path / "f_0003.png")
    assert np.array_equal(frame, iio.imread(tmp_path / "agx.png"))
    assert not np.array_equal(frame, iio.imread(tmp_path / "std.png"))


def test_chunk_sizes_follow_the_measured_costs():
    # The first wave: FIRST frames for each worker, so each measures cold and warm.
    assert chunking.first_wave(list(range(1, 25)), 2) == [[1, 2], [3, 4]]
    assert chunking.first_wave([1, 2, 3], 4) == [[1, 2], [3]]
    # A round trip of 10 ms against 10 ms warm frames: 20 frames keep it to 5%.
    assert chunking.chunk_size(cold=0.5, warm=0.010, overhead=0.010, left=1000, workers=2) == 20
    # Cheap round trips (a local pipe): single frames are fine.
    assert chunking.chunk_size(cold=0.5, warm=0.010, overhead=0.0001, left=1000, workers=2) == 1
    # Few frames left: balance (3 chunks per worker) wins over amortising.
    assert chunking.chunk_size(cold=0.05, warm=0.010, overhead=0.010, left=30, workers=2) == 5
    # A cold cost larger than a worker's share of what is left: long chunks.
    assert chunking.chunk_size(cold=5.0, warm=0.010, overhead=0.0001, left=60, workers=2) == 10
    # No chunk longer than MAX_CHUNK_SECONDS of warm renders.
    assert chunking.chunk_size(cold=0.1, warm=2.0, overhead=60.0, left=10000, workers=2) == \
        int(chunking.MAX_CHUNK_SECONDS / 2.0)


def test_a_worker_keeps_one_session_per_stage_and_settings(scene, tmp_path):
    """Chunks after the first on a worker are warm, at any size (the session is
    reconfigured); a changed file or another preset load anew, and a stale session is
    released."""
    from lantern.farm import sessions, tasks
    copy = tmp_path / "rig.usda"
    copy.write_bytes(scene.read_bytes())
    chunk = tasks.RenderChunk(scene=str(copy), frames=(1.0, 2.0),
                              targets=(tasks.ChunkOutput(None, 32, 18),))
    try:
        first = tasks.run(chunk)
        assert first.ok and first.cold is not None and len(first.warm) == 1
        again = tasks.run(replace(chunk, frames=(3.0, 4.0)))
        assert again.ok and again.cold is None and len(again.warm) == 2
        assert sessions.cached() == 1
        bigger = tasks.run(replace(chunk, targets=(tasks.ChunkOutput(None, 48, 27),)))
        assert bigger.cold is None and bigger.pixels[1.0].shape == (27, 48, 4)
        low = tasks.run(replace(chunk, preset="low"))
        assert low.cold is not None and sessions.cached() == 2
        stat = copy.stat()
        os.utime(copy, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
        reloaded = tasks.run(chunk)
        assert reloaded.cold is not None
        assert sessions.cached() == 1, "the sessions of the old file were not released"
        assert np.abs(reloaded.pixels[1.0] - first.pixels[1.0]).max() == 0.0
    finally:
        sessions.release_all()
    assert sessions.cached() == 0


def _pool_processes(pid):
    return [child for child in psutil.Process(pid).children()
            if "spawn_main" in " ".join(child.cmdline())
            and "resource_tracker" not in " ".join(child.cmdline())]


def _snapshot(folder):
    """The frames written so far: (inode, mtime) of each finished file. A write in
    progress (a `.name.XXXXXXXX` temporary, renamed when done) is not a frame yet."""
    frames = {}
    for name in os.listdir(folder):
        if name.startswith("."):
            continue
        st = os.stat(folder / name)
        frames[name] = (st.st_ino, st.st_mtime_ns)
    return frames


def test_a_dead_local_worker_has_its_chunk_run_again(scene, tmp_path):
    """A worker process killed mid-chunk: another runs the chunk, the frames it had
    written are kept (not written twice), no temporary file is left, the summary says so."""
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "lantern", "render", str(scene), "-o",
                             str(out / "f_####.exr"), "--frames", "1:24", "--size", "320x180",
                             "--chunk", "12", "-j", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not (
                out.is_dir() and any(n.startswith("f_00") for n in os.listdir(out))):
            time.sleep(0.005)
        before = _snapshot(out)
        # The first frame written is frame 1 or 13: kill the process with that chunk.
        victims = _pool_processes(proc.pid)
        assert len(victims) == 2, victims
        first_chunk = "f_0001.exr" in before
        # The pool's processes start in order, and the first chunk goes to the first.
        victim = sorted(victims, key=lambda p: p.create_time())[0 if first_chunk else 1]
        victim.send_signal(signal.SIGKILL)
        stdout, stderr = proc.communicate(timeout=180)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, stderr
    assert sorted(os.listdir(out)) == [f"f_{f:04d}.exr" for f in range(1, 25)]
    after = _snapshot(out)
    assert all(after[name] == before[name] for name in before), "a frame was written twice"
    assert f"its worker died while running it (local pid {victim.pid})" in stdout, stdout
    assert "24 frames written, 0 failed" in stdout


def test_resume_skips_outputs_newer_than_their_input(scene, tmp_path):
    copy = tmp_path / "rig.usda"
    copy.write_bytes(scene.read_bytes())
    out = tmp_path / "out" / "f_####.exr"
    args = ("render", copy, "-o", out, "--frames", "1:4", "--size", "32x18", "-j", "1")
    assert lantern(*args).returncode == 0
    (tmp_path / "out" / "f_0003.exr").unlink()
    proc = lantern(*args, "--resume")
    assert proc.returncode == 0, proc.stderr
    assert "1 frames written, 0 failed, 3 skipped (up to date)" in proc.stdout
    # The input changed: newer than every output, however long the renders took.
    newest = max(path.stat().st_mtime_ns for path in (tmp_path / "out").iterdir())
    os.utime(copy, ns=(copy.stat().st_atime_ns, newest + 10**9))
    proc = lantern(*args, "--resume")
    assert "4 frames written, 0 failed ->" in proc.stdout, proc.stdout


@pytest.mark.parametrize("args, words", [
    (["render", "{scene}", "-o", "{tmp}/f_####.exr", "--frames", "1:4", "--chunk", "0"],
     ["--chunk"]),
    (["render", "{scene}", "-o", "{tmp}/f_####.exr", "--frames", "1:4", "--scheduler",
      "somewhere:8786"], ["--scheduler", "tcp://"]),
    (["render", "{scene}", "-o", "{tmp}/f.exr", "--scheduler", "tcp://127.0.0.1:1"],
     ["--frames"]),
    (["render", "{scene}", "-o", "{tmp}/f_####.exr", "--frames", "1:4", "-j", "0"], ["-j"]),
    (["export", "a.blend", "b.blend", "-o", "{tmp}/out", "--collect"], ["--textures copy"]),
    (["export", "a.blend", "-o", "{tmp}/a.usdc", "--resume"], ["folder"]),
])
def test_farm_usage_errors_exit_2_before_any_work(scene, tmp_path, args, words):
    before = set(os.listdir(tmp_path))
    proc = lantern(*[a.format(scene=scene, tmp=tmp_path) for a in args])
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    line = proc.stderr.strip().splitlines()[-1]
    assert all(word in line for word in words), line
    assert set(os.listdir(tmp_path)) == before
