"""core/: the pure numpy shared by exporters and engine, against independent answers."""
import os

import numpy as np
import pytest

from lantern.core import files, lights, presets, transforms


def random_rotations(n, seed=3):
    q = np.random.default_rng(seed).normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return q, np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)


def test_quaternions_from_matrices_recover_the_rotation():
    q, r = random_rotations(500)
    got = transforms.quaternions_from_matrices(r)
    # q and -q are one rotation: compare up to sign.
    sign = np.sign(np.sum(got * q, axis=1))[:, None]
    assert np.abs(got * sign - q).max() < 1e-12
    # Every pivot case of Shepperd's method, including the half-turns.
    half_turns = np.array([np.diag(d) for d in ((1, -1, -1), (-1, 1, -1), (-1, -1, 1))], float)
    assert np.allclose(np.abs(transforms.quaternions_from_matrices(half_turns)),
                       [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]])


def test_quaternion_multiply_composes_rotations():
    (qa, ra), (qb, rb) = random_rotations(50, 1), random_rotations(50, 2)
    both = transforms.quaternions_from_matrices(ra @ rb)
    prod = transforms.quaternion_multiply(qa, qb)
    assert np.abs(np.abs(np.sum(both * prod, axis=1)) - 1).max() < 1e-12


def test_affine_inverse_and_normal_matrix():
    rng = np.random.default_rng(5)
    m = np.tile(np.eye(4), (20, 1, 1))
    m[:, :3, :] = rng.normal(size=(20, 3, 4))
    assert np.abs(transforms.affine_inverse(m) - np.linalg.inv(m)).max() < 1e-9
    n = transforms.normal_matrix(m[0])
    assert np.allclose(n, np.linalg.inv(m[0][:3, :3]).T)
    flat = np.diag([1.0, 1.0, 0.0, 1.0])           # singular: kept, never a division by 0
    assert np.array_equal(transforms.normal_matrix(flat), flat[:3, :3])
    both = np.concatenate([m, flat[None]])          # a batch: each matrix as alone
    batch = transforms.normal_matrix(both)
    assert np.abs(batch[:-1] - np.linalg.inv(m[:, :3, :3]).transpose(0, 2, 1)).max() < 1e-9
    assert np.array_equal(batch[-1], flat[:3, :3])


def test_transformed_boxes_hold_every_transformed_corner():
    rng = np.random.default_rng(9)
    lo = rng.normal(size=(30, 3))
    hi = lo + rng.random((30, 3))
    m = np.tile(np.eye(4), (30, 1, 1))
    m[:, :3, :] = rng.normal(size=(30, 3, 4))
    wlo, whi = transforms.transform_aabbs(lo, hi, m)
    for i in range(30):
        c = np.c_[transforms.aabb_corners(lo[i], hi[i]), np.ones(8)] @ m[i].T
        assert np.allclose(c[:, :3].min(0), wlo[i]) and np.allclose(c[:, :3].max(0), whi[i])


def test_look_at_and_projections():
    world = transforms.look_at(np.array([1.0, 2, 3]), np.zeros(3), np.array([0, 0, 1.0]))
    assert np.allclose(world[:3, :3] @ world[:3, :3].T, np.eye(3))
    assert np.allclose(-world[:3, 2], -np.array([1.0, 2, 3]) / np.linalg.norm([1.0, 2, 3]))
    down = transforms.look_at(np.zeros(3), np.array([0, 0, -1.0]), np.array([0, 0, 1.0]))
    assert np.all(np.isfinite(down))                 # up along the view: still a basis
    p = transforms.frustum(-1, 1, -1, 1, 1, 10)
    near = p @ [0, 0, -1, 1]
    far = p @ [0, 0, -10, 1]
    assert np.isclose(near[2] / near[3], -1) and np.isclose(far[2] / far[3], 1)
    o = transforms.ortho(-2, 2, -1, 1, 0.5, 5)
    assert np.allclose(o @ [2, 1, -5, 1], [1, 1, 1, 1])


def test_atomic_write_never_leaves_a_half_file(tmp_path):
    target = tmp_path / "out.txt"
    files.atomic_write(str(target), lambda tmp: open(tmp, "w").write("one"))
    with pytest.raises(RuntimeError):
        def broken(tmp):
            open(tmp, "w").write("half")
            raise RuntimeError("disk full")
        files.atomic_write(str(target), broken)
    assert target.read_text() == "one" and os.listdir(tmp_path) == ["out.txt"]


def test_light_kinds_round_trip_between_blender_and_usd():
    cases = {("POINT", None): "point", ("SPOT", None): "spot", ("SUN", None): "sun",
             ("AREA", "SQUARE"): "rect", ("AREA", "RECTANGLE"): "rect",
             ("AREA", "DISK"): "disk", ("AREA", "ELLIPSE"): "disk"}
    for (kind, shape), name in cases.items():
        assert lights.kind_of_blender(kind, shape) == name
        schema = lights.KINDS[name].usd_schema
        assert lights.kind_of_usd(schema, spot=name == "spot") == name
    assert lights.kind_of_usd("DomeLight") is None
    with pytest.raises(ValueError, match="HEMI"):
        lights.kind_of_blender("HEMI")


def test_presets_table():
    assert list(presets.PRESETS) == ["low", "medium", "high", "ultra"]
    sizes = [p.shadow_size for p in presets.PRESETS.values()]
    assert sizes == sorted(sizes) and presets.DEFAULT in presets.PRESETS
    with pytest.raises(ValueError, match="low, medium, high, ultra"):
        presets.preset("insane")


def test_frame_paths_and_one_line_errors():
    from lantern.core.text import error_text, frame_path, one_line
    assert frame_path("/out/f_####.png", 12) == "/out/f_0012.png"
    assert frame_path("/out/f_##.exr", 12.5) == "/out/f_12.5.exr"
    assert frame_path("a#_#.png", 3) == "a3_#.png"      # the first run of '#' only
    pxr = ("Error in 'Parse' at line 3 in file x.usda : 'bad token'\n"
           "Error in 'Parse' at line 3 in file x.usda : 'bad token'\nsecond reason")
    assert one_line(pxr) == "bad token; second reason"
    assert one_line("") == "no reason given"

    class Undecodable(Exception):
        def __str__(self):
            raise UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte")
    assert "not UTF-8" in error_text(Undecodable())


def test_ctrl_c_inside_deferred_is_raised_when_the_block_ends():
    """core.interrupt.deferred: a step that must not stop half way (starting a worker)
    finishes, then the Ctrl-C that came meanwhile is raised."""
    import signal

    from lantern.core import interrupt
    previous = signal.getsignal(signal.SIGINT)
    interrupt.raise_keyboard_interrupt()
    steps = []
    try:
        with pytest.raises(KeyboardInterrupt):
            with interrupt.deferred():
                os.kill(os.getpid(), signal.SIGINT)
                steps += ["signalled"]
                for _ in range(1000):       # bytecodes, where the handler runs
                    pass
                steps += ["finished"]
            steps += ["after"]
        assert steps == ["signalled", "finished"]
    finally:
        interrupt.restore(previous)
