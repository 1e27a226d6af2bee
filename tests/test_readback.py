"""The GL context and the image's way back to host memory (engine/gpu/context.py,
engine/gpu/readback.py, engine/gpu/timers.py), on both GL paths:

- the context asks for a version at least as high as the one the engine uses, and the
  stats name the renderer, its version and the path taken;
- the image flipped on the GPU and read into the caller's buffer equals GL's
  bottom-up rows flipped in numpy (what the engine did before), bit for bit;
- the GPU's count of non-finite pixels equals numpy's, on the compute path (GL 4.3+)
  and the occlusion-query path (GL 3.3);
- half floats are within float16 rounding of float32, resolved into a half-float
  image so that the read is a copy;
- the queued (pipelined) sequence equals blocking renders, frame for frame;
- every pass that ran has a GPU time >= 0, and they add up to at most the frame;
- no draw reads GPU memory that nothing wrote: fresh buffers and textures filled with
  garbage (as a driver may hand them out; llvmpipe hands out zeros) give the same
  image, with the vertex and index stores grown past their first size;
- grown stores hold every byte written into them before and after they grew (NVIDIA's
  driver lost the copied part of the index buffer until growth waited for its copy)."""
import numpy as np
import pytest
from pxr import Gf, UsdGeom

from lantern.engine import RenderSettings, Session, render_stage
from lantern.engine.gpu import readback, resources, stores
from lantern.engine.gpu.context import GL_VERSIONS, Features, run_gl

import session_scenes
import shadow_scenes

W, H = 64, 40
PATHS = {"gl43": "45", "gl33": "33"}       # LANTERN_MAX_GL per path


@pytest.fixture(params=sorted(PATHS))
def gl_path(request, monkeypatch):
    monkeypatch.setenv("LANTERN_MAX_GL", PATHS[request.param])
    return request.param


def _lit_stage():
    stage = session_scenes.cubes_stage(n=9, lights=("point",))
    return stage


def test_the_context_asks_for_at_least_what_it_uses(gl_path):
    requested, version = run_gl(lambda gl: (gl.requested, gl.version))
    assert requested in GL_VERSIONS
    used = Features.of(version).version        # LANTERN_MAX_GL caps the paths
    assert used <= int(PATHS[gl_path]) * 10
    result = render_stage(_lit_stage(), RenderSettings(width=W, height=H))
    assert result.stats["gl_requested"] == requested >= version >= used
    assert result.stats["gl_renderer"] and result.stats["gl_version"]
    expected = "multi-draw (GL 4.3)" if gl_path == "gl43" else "draw per object (GL 3.3)"
    assert result.stats["gl_path"].startswith(expected)


def test_gpu_flip_into_the_callers_buffer_equals_the_numpy_flip(gl_path):
    with Session(_lit_stage(), RenderSettings(width=W, height=H)) as session:
        top = session.render().rgba
        block = bytearray(W * H * 4 * 4)          # as a shared-memory block would be
        bottom = session.render(out=memoryview(block), bottom_up=True).rgba
        assert np.shares_memory(bottom, np.frombuffer(block, np.float32))
        assert top.dtype == np.float32 and top.shape == (H, W, 4)
        assert np.array_equal(top, bottom[::-1])
        assert np.array_equal(top, np.frombuffer(block, np.float32).reshape(H, W, 4)[::-1])
        assert top[..., :3].max() > 0
        with pytest.raises(ValueError, match="read-back buffer"):
            session.render(out=bytearray(16))


def test_the_gpu_counts_non_finite_pixels_as_numpy_does(gl_path):
    stage = shadow_scenes.new_stage(half=3.0)
    shadow_scenes.add_light(stage, "point", pos=(0.0, 0.0, 0.3), power=3e38 * np.pi,
                            radius=0.0, shadow=False)
    shadow_scenes.add_camera(stage, eye=(3.0, -5.0, 3.0), target=(0, 0, 0))
    result = render_stage(stage, RenderSettings(width=W, height=H, fxaa=False))
    bad = int((~np.isfinite(result.rgba).all(axis=-1)).sum())
    assert result.stats["nonfinite_pixels"] == bad > 0
    assert any(f"{bad} pixels" in w for w in result.warnings), result.warnings


def test_half_float_readback_is_float32_rounded(gl_path):
    with Session(_lit_stage(), RenderSettings(width=W, height=H)) as session:
        full = session.render().rgba
        session.configure(readback="half")
        half = session.render().rgba
    assert half.dtype == np.float16 and half.shape == full.shape
    # Within one float16 step of the float32 value (either rounding direction).
    step = np.spacing(np.abs(full).astype(np.float16)).astype(np.float32)
    assert np.all(np.abs(half.astype(np.float32) - full) <= step)
    assert np.abs(half.astype(np.float32) - full).max() > 0    # really half floats


def test_a_read_copies_an_image_of_its_own_format(gl_path, monkeypatch):
    """The resolve writes the format the caller reads, so no driver converts as it
    reads (NVIDIA's did half floats on the CPU: 68 ms at 1920x1080, float32 2.2 ms)."""
    read, seen = readback.Readback.read, []

    def spy(self, slot, fbo, size, request):
        seen.append((request.format, fbo.color_attachments[0].dtype))
        return read(self, slot, fbo, size, request)
    monkeypatch.setattr(readback.Readback, "read", spy)
    with Session(_lit_stage(), RenderSettings(width=W, height=H)) as session:
        session.render()
        session.configure(readback="half")
        session.render()
    assert seen == [("float32", "f4"), ("half", "f2")]


def test_queued_sequence_equals_blocking_renders(gl_path):
    stage = session_scenes.time_sampled_mesh_stage(frames=6, grid=24)
    frames = [1, 2, 4, 6]
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        queued = list(session.render_frames(frames))
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        blocking = [session.render(frame=f) for f in frames]
    assert [f for f, _ in queued] == frames
    for (_, q), b in zip(queued, blocking):
        assert np.array_equal(q.rgba, b.rgba)
    latency = [q.stats["readback_latency_frames"] for _, q in queued]
    assert latency == [1, 1, 1, 0]


def test_queued_sequence_reports_a_bad_frame_and_goes_on():
    stage = session_scenes.time_sampled_mesh_stage(frames=3, grid=8)
    with Session(stage, RenderSettings(width=W, height=H, camera="/no/camera")) as session:
        out = list(session.render_frames([1, 2]))
    assert [f for f, _ in out] == [1, 2]
    assert all(isinstance(r, ValueError) and "/no/camera" in str(r) for _, r in out)


def test_every_pass_that_ran_has_a_gpu_time(gl_path):
    with Session(_lit_stage(), RenderSettings(width=W, height=H)) as session:
        session.render()
        result = session.render()
    ran = result.stats["passes"]
    assert set(result.gpu_timings) == set(ran)
    assert all(t >= 0.0 for t in result.gpu_timings.values()), result.gpu_timings
    assert sum(result.gpu_timings.values()) <= result.timings["total"]
    assert 0.0 <= result.stats["cpu_seconds"] <= result.timings["total"]


# What a driver's recycled memory might hold instead of llvmpipe's zeros: words that
# read as indices of vertices that exist (a stray triangle), or as floats that read as
# vertices inside the view.
JUNK = {"indices": lambda rng, n: rng.integers(0, 64, n).astype(np.uint32),
        "floats": lambda rng, n: rng.uniform(-2.0, 2.0, n).astype(np.float32)}


def _garbage(monkeypatch, kind):
    """Fresh GL buffers and textures that nothing wrote hold JUNK[kind]."""
    buffer, texture = resources.Uploads.buffer, resources.Uploads.texture
    rng = np.random.default_rng(7)

    def junk(n):
        return JUNK[kind](rng, (n + 3) // 4).tobytes()[:n]

    def dirty_buffer(self, data=None, *, kind, reserve=0):
        made = buffer(self, data, kind=kind, reserve=reserve)
        if data is None:
            made.write(junk(made.size))
        return made

    def dirty_texture(self, size, components, data=None, *, kind, dtype="f1", **kw):
        made = texture(self, size, components, data, kind=kind, dtype=dtype, **kw)
        if data is None:
            made.write(junk(size[0] * size[1] * components * int(dtype[1])))
        return made
    monkeypatch.setattr(resources.Uploads, "buffer", dirty_buffer)
    monkeypatch.setattr(resources.Uploads, "texture", dirty_texture)


def _grown_stores_stage():
    """Meshes that outgrow the static store's first 16,384 vertices and 32,768
    indices after smaller meshes are in it, as a level-2 subdivided Suzanne does."""
    stage = session_scenes.cubes_stage(n=4, lights=("point",), camera=False)
    shadow_scenes.add_camera(stage, eye=(1.5, -8.0, 6.0), target=(1.5, 0.0, 0.5))
    xs, ys = np.meshgrid(np.linspace(-2, 2, 150), np.linspace(-2, 2, 150))
    grid = 150
    rows, cols = np.meshgrid(np.arange(grid - 1), np.arange(grid - 1), indexing="ij")
    a = (rows * grid + cols).ravel()
    quads = np.stack([a, a + 1, a + grid + 1, a + grid], 1)
    mesh = UsdGeom.Mesh.Define(stage, "/root/dense")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreateFaceVertexCountsAttr(np.full(len(quads), 4, np.int32))
    mesh.CreateFaceVertexIndicesAttr(quads.ravel().astype(np.int32))
    z = 0.3 * np.sin(3 * xs) * np.cos(2 * ys) + 0.5
    mesh.CreatePointsAttr(np.stack([xs.ravel(), ys.ravel(), z.ravel()], 1).astype(np.float32))
    mesh.AddTranslateOp().Set(Gf.Vec3d(4.0, 0.0, 0.0))
    return stage


@pytest.mark.parametrize("junk", sorted(JUNK))
def test_no_draw_reads_memory_that_nothing_wrote(gl_path, junk, monkeypatch):
    stage = _grown_stores_stage()
    settings = RenderSettings(width=W, height=H)
    with Session(stage, settings) as session:
        clean = session.render()
        store = run_gl(lambda gl: session._renderer.geometry.static)
        assert store.vertices.capacity > 1 << 14 and store.indices.capacity > 1 << 15
    _garbage(monkeypatch, junk)
    dirty = render_stage(stage, settings)
    assert clean.stats["nonfinite_pixels"] == dirty.stats["nonfinite_pixels"] == 0
    assert np.array_equal(clean.rgba, dirty.rgba)


def test_grown_stores_hold_every_byte_written(gl_path, monkeypatch):
    written = []        # (store, "vbo" or "ibo", byte offset, bytes) in the order written
    write_vertices = stores.VertexStore.write_vertices
    write_indices = stores.VertexStore.write_indices

    def vertices(store, slot, data):
        written.append((store.name, "vbo", slot.first_vertex * stores.VERTEX_BYTES,
                        np.ascontiguousarray(data, np.float32).tobytes()))
        write_vertices(store, slot, data)

    def indices(store, slot, data):
        absolute = np.asarray(data, np.uint32) + np.uint32(slot.first_vertex)
        written.append((store.name, "ibo", slot.first_index * 4, absolute.tobytes()))
        write_indices(store, slot, data)
    monkeypatch.setattr(stores.VertexStore, "write_vertices", vertices)
    monkeypatch.setattr(stores.VertexStore, "write_indices", indices)
    with Session(_grown_stores_stage(), RenderSettings(width=W, height=H)) as session:
        session.render()
        static = run_gl(lambda gl: session._renderer.geometry.static)
        held = run_gl(lambda gl: {"vbo": static.vbo.read(), "ibo": static.ibo.read()})
    assert static.vertices.capacity > 1 << 14 and static.indices.capacity > 1 << 15
    for buffer in ("vbo", "ibo"):
        expected = np.zeros(len(held[buffer]), np.uint8)
        mask = np.zeros(len(held[buffer]), bool)
        for store, name, offset, data in written:
            if (store, name) == ("static", buffer):
                expected[offset:offset + len(data)] = np.frombuffer(data, np.uint8)
                mask[offset:offset + len(data)] = True
        got = np.frombuffer(held[buffer], np.uint8)
        assert mask.sum() > 0 and np.array_equal(got[mask], expected[mask]), buffer


def test_a_sequence_broken_off_leaves_the_session_usable():
    stage = session_scenes.time_sampled_mesh_stage(frames=4, grid=8)
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        frames = session.render_frames([1, 2, 3])
        next(frames)                            # frame 2 is queued behind a fence
        frames.close()
        again = session.render(frame=3)
        assert list(session.render_frames([3]))[0][1].rgba.tolist() == again.rgba.tolist()


def test_a_moving_view_takes_the_size_its_frame_time_allows():
    from lantern.engine.host import protocol as p
    assert p.interactive_scale(None, None) == p.INTERACTIVE_SCALE      # measure first
    budget = p.INTERACTIVE_BUDGET
    # A GPU that drew half size in a tenth of the budget draws the full size next.
    assert p.interactive_scale(0.5, budget / 10) == 1.0
    # llvmpipe: half size took 4x the budget -> a quarter of its pixels fit.
    assert p.interactive_scale(0.5, budget * 4) == 0.25
    # In between: the largest step that fits.
    assert p.interactive_scale(1.0, budget * 1.5) == 0.75
    assert p.interactive_scale(1.0, budget * 3.0) == 0.5


@pytest.mark.parametrize("preset", ["low", "ultra"])
def test_a_new_preset_reads_and_uploads_nothing_and_equals_a_fresh_session(preset):
    stage = session_scenes.cubes_stage(n=9, lights=("point", "spot"))
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        session.render()
        session.configure(preset=preset)
        changed = session.render()
        session.configure(preset="medium")
        back = session.render()
    assert changed.stats["prims_read"] == 0 and back.stats["prims_read"] == 0
    assert changed.stats["bytes_by_kind"].get("mesh", 0) == 0
    assert back.stats["bytes_by_kind"].get("mesh", 0) == 0
    fresh = render_stage(stage, RenderSettings(width=W, height=H, preset=preset))
    assert np.array_equal(changed.rgba, fresh.rgba)
    again = render_stage(stage, RenderSettings(width=W, height=H))
    assert np.array_equal(back.rgba, again.rgba)


def test_each_preset_keeps_its_shadow_maps_until_the_scene_changes():
    """A view that settles from the interactive preset back to the scene's finds that
    preset's shadow maps drawn; an edit in between draws them again."""
    stage = session_scenes.cubes_stage(n=9, lights=("point", "spot"))
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        first = session.render()
        session.configure(preset="low")
        session.render()
        session.configure(preset="medium")
        back = session.render()
        assert first.stats["shadow_maps_rendered"] > 0
        assert back.stats["shadow_maps_rendered"] == 0
        assert np.array_equal(back.rgba, first.rgba)
        session.configure(preset="low")
        op = UsdGeom.Xformable(stage.GetPrimAtPath("/root/c0004")).GetOrderedXformOps()[0]
        op.Set(op.Get() + Gf.Vec3d(0.3, 0.0, 0.2))
        session.render()
        session.configure(preset="medium")
        edited = session.render()
    assert edited.stats["shadow_maps_rendered"] > 0
    fresh = render_stage(stage, RenderSettings(width=W, height=H))
    assert np.array_equal(edited.rgba, fresh.rgba)


@pytest.mark.parametrize("mode", ["direct", "mapped"])
def test_both_read_modes_read_the_same_pixels_into_memory_the_caller_owns(mode, monkeypatch):
    """LANTERN_READBACK: glReadPixels straight into the caller's memory, or through a
    persistently mapped pixel buffer (GL 4.4) and one memcpy. Blocking into a new
    array or a reused buffer, half floats, and queued, each mode gives the pixels of
    the other; an array returned without `out=` is the caller's own (a later render
    leaves it as it was), and the non-finite count and warning are the same."""
    monkeypatch.setenv("LANTERN_READBACK", mode)
    stage = session_scenes.time_sampled_mesh_stage(frames=3, grid=16)
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        first = session.render(frame=1)
        assert first.stats["readback_mode"] == mode
        kept = first.rgba.copy()
        buffer = np.empty((H, W, 4), np.float32)
        into = [session.render(frame=f, out=buffer).rgba.copy() for f in (2, 3)]
        assert np.shares_memory(session.render(frame=3, out=buffer).rgba, buffer)
        second = session.render(frame=2)
        assert np.array_equal(first.rgba, kept) and not np.shares_memory(first.rgba, second.rgba)
        session.configure(readback="half")
        half = session.render(frame=2).rgba
        session.configure(readback="float32")
        queued = [r.rgba for _, r in session.render_frames([1, 2, 3])]
    with monkeypatch.context() as m:
        m.setenv("LANTERN_READBACK", "direct")
        with Session(stage, RenderSettings(width=W, height=H)) as session:
            direct = [session.render(frame=f).rgba for f in (1, 2, 3)]
            session.configure(readback="half")
            direct_half = session.render(frame=2).rgba
    assert np.array_equal(first.rgba, direct[0]) and np.array_equal(second.rgba, direct[1])
    assert all(np.array_equal(a, b) for a, b in zip(into, direct[1:]))
    assert all(np.array_equal(a, b) for a, b in zip(queued, direct))
    assert half.dtype == np.float16 and np.array_equal(half, direct_half)
    bad = shadow_scenes.new_stage(half=3.0)
    shadow_scenes.add_light(bad, "point", pos=(0.0, 0.0, 0.3), power=3e38 * np.pi,
                            radius=0.0, shadow=False)
    shadow_scenes.add_camera(bad, eye=(3.0, -5.0, 3.0), target=(0, 0, 0))
    result = render_stage(bad, RenderSettings(width=W, height=H, fxaa=False))
    count = int((~np.isfinite(result.rgba).all(axis=-1)).sum())
    assert result.stats["nonfinite_pixels"] == count > 0
    assert any(f"{count} pixels" in w for w in result.warnings), result.warnings


@pytest.mark.parametrize("software", [True, False])
def test_a_software_device_is_not_asked_for_gl_46(monkeypatch, software):
    """Mesa's software device offers GL 4.5 at most: its context is asked for 4.5 first
    (a refused 4.6 cost every new process 20 ms); a GPU is asked for 4.6 first (NVIDIA
    gives exactly the version asked for)."""
    from dataclasses import replace

    from lantern.engine.gpu import context, devices
    listed = devices.egl_devices() or (devices.Device(0, True, None),)
    monkeypatch.setattr(devices, "egl_devices",
                        lambda: tuple(replace(d, software=software) for d in listed))
    asked = []

    def make(index, version):
        asked.append(version)
        raise RuntimeError("no context here")
    monkeypatch.setattr(devices, "make_backend", make)
    monkeypatch.setattr(devices, "asked", lambda: 0)     # no fallback to glcontext's own
    with pytest.raises(RuntimeError, match="no headless OpenGL"):
        context._backend(0)
    assert asked[0] == (450 if software else 460) and asked[-1] == 330
