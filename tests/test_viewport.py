"""The viewport path without a window: real depsgraph edits become messages to the
engine host, sized by what changed, and its frames come back and are painted (up to
the `gpu` call, which background mode lacks).

Blender fills `depsgraph.updates` only inside update callbacks, so the viewport is
synced from Blender's depsgraph_update_post and frame_change_post handlers, as
view_update would be. Region and view are plain objects and matrices."""
import time
from types import SimpleNamespace

import numpy as np
import pytest

W, H = 64, 36


@pytest.fixture(scope="module")
def addon():
    import lantern
    lantern.register()
    yield
    lantern.unregister()


def _rig(scene):
    """A three-bone armature bending a cylinder over frames 1-10 (UsdSkel in the
    live stage: a frame change is a pose)."""
    import bpy
    data = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", data)
    scene.collection.objects.link(rig)
    rig.location = (2.5, 0.0, 0.0)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    previous = None
    for b in range(3):
        bone = data.edit_bones.new(f"B{b}")
        bone.head, bone.tail, bone.parent = (0, 0, b * 0.5), (0, 0, (b + 1) * 0.5), previous
        previous = bone
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.ops.mesh.primitive_cylinder_add(radius=0.3, depth=1.5, location=(2.5, 0.0, 0.75),
                                        vertices=12)
    body = bpy.context.object
    bpy.ops.object.transform_apply(location=False)
    body.name = "Body"
    body.parent = rig
    body.matrix_parent_inverse = rig.matrix_world.inverted()
    body.modifiers.new("Armature", "ARMATURE").object = rig
    z = np.array([v.co.z for v in body.data.vertices])
    for b in range(3):
        group = body.vertex_groups.new(name=f"B{b}")
        for v in np.flatnonzero(np.abs(z - (b + 0.5) * 0.5) < 0.5):
            group.add([int(v)], 1.0 - abs(z[v] - (b + 0.5) * 0.5), "REPLACE")
    for frame, angle in ((1, 0.0), (10, 0.6)):
        for pb in rig.pose.bones:
            pb.rotation_mode = "XYZ"
            pb.rotation_euler = (angle, 0.0, 0.0)
            pb.keyframe_insert("rotation_euler", frame=frame)
    return rig


def _scene():
    """A plane, two cubes (one painted), a sun, a camera and the rig."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 10
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.lantern.preset = "medium"
    # Lit directly: an edit changes the image where it is (the bounce would spread a
    # moved cube's light over the frame, and rebuild its field at each edit).
    scene.cycles.max_bounces = 0
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    for name, x in (("Cube", -2.0), ("Other", 0.0)):
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=(x, 0.0, 0.5))
        bpy.context.object.name = name
    paint = bpy.data.materials.new("paint")
    paint.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.1, 0.1, 1)
    bpy.data.objects["Cube"].data.materials.append(paint)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.rotation_euler = 3.0, (0.5, 0.3, 0.0)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0.0, -9.0, 3.0), (np.radians(75), 0.0, 0.0)
    for ob in (sun, camera):
        scene.collection.objects.link(ob)
    scene.camera = camera
    _rig(scene)
    scene.frame_set(1)
    return scene


def _camera_view(scene, depsgraph, scale=1.0, border=None):
    from lantern.addon.viewport import view_request
    camera = scene.camera.evaluated_get(depsgraph)
    view = np.array(camera.matrix_world.inverted())
    window = np.array(camera.calc_matrix_camera(depsgraph, x=W, y=H))
    return view_request((W, H), view, window, scale, border)


class Viewport:
    """A viewport synced from Blender's handlers, painting into numpy."""

    def __init__(self):
        import bpy
        from lantern.addon.viewport import ViewportRender
        self.render = ViewportRender()
        self.painted = []
        self.mark = 0               # frames before the last edit: wait for a newer one
        self.handlers = (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post)
        for handlers in self.handlers:
            handlers.append(self.on_update)
        self.render.update(bpy.context.evaluated_depsgraph_get())

    def on_update(self, scene, depsgraph):
        self.render.update(depsgraph)

    def paint(self, number, pixels, rect):
        self.painted.append((number, pixels[::-1].copy(), rect))

    def frame(self, view, preset="medium", timeout=60.0):
        """Draws until the final frame of the current view and stage is painted."""
        import bpy
        host, name = self.render.host, self.render.name
        start = time.monotonic()
        while time.monotonic() - start < timeout:
            self.render.draw(bpy.context.evaluated_depsgraph_get(), view, self.paint, preset)
            channel = host.channel(name)           # a new one when the engine restarted
            latest = channel.latest
            if channel.error is not None:
                raise AssertionError(channel.error)
            if latest is not None and latest.final and latest.request == channel.requested \
                    and latest.number > self.mark and self.painted and self.painted[-1][0] == latest.number \
                    and not self.render.waiting():
                return self.painted[-1][1], latest
            time.sleep(0.01)
        raise TimeoutError("no final frame")

    def close(self):
        for handlers in self.handlers:
            handlers.remove(self.on_update)
        self.render.close()


@pytest.fixture
def viewport(addon):
    scene = _scene()
    vp = Viewport()
    yield scene, vp
    vp.close()


def _edit(vp, action):
    """The messages an edit sent: [(kind, bytes)], and the fragments of its edits."""
    import bpy
    host = vp.render.host
    before = host.messages
    vp.mark = host.channel(vp.render.name).frames
    action()
    bpy.context.view_layer.update()
    sent = [(kind, size) for kind, scene, size in host.sent_since(before) if scene == vp.render.name]
    return sent, list(vp.render.live.last)


def _fresh(scene, view, **settings):
    """The same view rendered in this process from a fresh live export (`settings`: more
    RenderSettings)."""
    import bpy
    from pxr import Usd
    from lantern.engine import RenderSettings, Session
    from lantern.exporters.live import export_live
    stage = Usd.Stage.CreateInMemory()
    export_live(bpy.context.evaluated_depsgraph_get(), stage, lambda m: None)
    with Session(stage, RenderSettings(width=view.size[0], height=view.size[1],
                                       preset=scene.lantern.preset, **settings)) as session:
        return session.render(view_matrix=view.view, projection_matrix=view.projection).rgba


def _changed(a, b):
    return np.abs(a - b)[..., :3].max(axis=-1) > 1e-3


def test_edits_send_the_minimal_delta_and_the_image_follows(viewport):
    import bpy
    scene, vp = viewport
    view = _camera_view(scene, bpy.context.evaluated_depsgraph_get())
    before, first = vp.frame(view)
    assert first.preset == "medium" and first.final
    np.testing.assert_allclose(before, _fresh(scene, view), atol=2e-3)

    # Moving one object sends that object's transform: one small message.
    cube = bpy.data.objects["Cube"]
    sent, exports = _edit(vp, lambda: setattr(cube, "location", (-2.0, 0.0, 1.5)))
    assert exports == [("object", "Cube")]
    (kind, size), = [s for s in sent if s[0] == "edit"]
    assert size < 700, size
    after, _ = vp.frame(view)
    moved = _changed(before, after)
    cols = np.nonzero(moved.any(axis=0))[0]
    assert moved.any() and cols.max() < W // 2          # the cube is left of the middle
    np.testing.assert_allclose(after, _fresh(scene, view), atol=2e-3)

    # Editing a mesh re-exports that mesh alone.
    def lift():
        for v in cube.data.vertices:
            if v.co.z > 0:
                v.co.z += 0.5
        cube.data.update()
    sent, exports = _edit(vp, lift)
    assert ("geometry", "Cube") in exports and {k for k, _ in exports} <= {"geometry", "object"}
    edits = [s for s in sent if s[0] == "edit"]
    assert len(edits) == 1 and edits[0][1] < 4000, edits
    taller, _ = vp.frame(view)
    assert _changed(after, taller).any()

    # A material edit sends that material; the cube's colour changes, nothing else.
    bsdf = bpy.data.materials["paint"].node_tree.nodes["Principled BSDF"]
    sent, exports = _edit(vp, lambda: setattr(bsdf.inputs["Base Color"], "default_value",
                                               (0.1, 0.1, 0.8, 1)))
    assert ("material", "paint") in exports
    edits = [s for s in sent if s[0] == "edit"]
    assert len(edits) == 1 and edits[0][1] < 1500, edits
    blue, _ = vp.frame(view)
    recoloured = _changed(taller, blue)
    assert recoloured.any() and np.nonzero(recoloured.any(axis=0))[0].max() < W // 2
    assert blue[recoloured][:, 2].mean() > taller[recoloured][:, 2].mean()

    # A frame change on the rig sends joint channels only.
    fragments = []
    real_edit = vp.render.host.edit

    def spy(scene_name, fragment):
        fragments.append(fragment)
        return real_edit(scene_name, fragment)

    vp.render.host.edit = spy
    try:
        sent, exports = _edit(vp, lambda: scene.frame_set(8))
    finally:
        del vp.render.host.edit
    assert exports == [("pose", "Rig")]
    (fragment,) = fragments
    paths = fragment["copy"] + fragment["fields"] + fragment["remove"]
    assert paths and all(p.split(".")[0].endswith("/Animation") for p in paths), paths
    assert {p.split(".")[1] for p in paths} <= {"translations", "rotations", "scales"}
    joints = 3
    (kind, size), = [s for s in sent if s[0] == "edit"]
    assert size < 1200 + joints * 40, size
    posed, frame = vp.frame(view)
    bent = _changed(blue, posed)
    # The rig is right of the middle (its shadow and the sun's cascade fit, which
    # follows what casts, reach a few pixels further).
    assert bent[:, W // 2:].sum() > 0.8 * bent.sum() > 0
    # Posed on the GPU once, no mesh re-uploaded: the moving frame (interactive preset)
    # skins the rig, and the same Session draws the settled frame without skinning
    # again, unless the settled frame was the first at this time.
    assert frame.stats["meshes_uploaded"] == 0 and frame.stats["meshes_skinned"] in (0, 1), \
        (frame.stats["bytes_by_kind"], frame.stats["prims_read"], fragment["copy"])
    assert frame.stats["bytes_by_kind"].get("mesh", 0) == 0
    np.testing.assert_allclose(posed, _fresh(scene, view), atol=2e-3)


def test_a_graph_edit_draws_the_old_variant_until_the_new_one_is_made(viewport):
    """A Mix node's blend type changes the network's shape: the engine host draws the
    material as it was while its compiler's helper makes the new variant, keeps the
    frames not final meanwhile, and its final frame draws the edit with a program it
    loaded, not compiled (engine/gpu/compiler.py)."""
    import bpy
    import pattern_scenes
    scene, vp = viewport
    paint = bpy.data.materials["paint"]
    bsdf = paint.node_tree.nodes["Principled BSDF"]
    sent, _ = _edit(vp, lambda: pattern_scenes._mix_blend("MULTIPLY")(paint.node_tree, bsdf))
    view = _camera_view(scene, bpy.context.evaluated_depsgraph_get())
    before, _ = vp.frame(view)
    mix = next(n for n in paint.node_tree.nodes if n.bl_idname == "ShaderNodeMix")

    def edit():     # clamped: a shape no other test draws
        mix.blend_type, mix.clamp_result = "SCREEN", True
    channel = vp.render.host.channel(vp.render.name)
    frames = []

    class Recorded(type(channel.event)):
        def set(self):              # on the reader thread, as each frame arrives
            frames.append(channel.latest)
            super().set()
    channel.event = Recorded()
    _edit(vp, edit)
    after, frame = vp.frame(view)
    first = frames[0]
    assert first.stats["programs_pending"] == 1 and not first.final, first.stats
    assert all(f.stats["programs_compiled"] == 0 for f in frames), [f.stats for f in frames]
    assert frame.stats["programs_pending"] == 0 and frame.stats["programs_loaded"] == 1
    assert _changed(before, after).any()
    np.testing.assert_allclose(after, _fresh(scene, view), atol=2e-3)

    # A value edit (the Mix's factor) is parameters only: a small message, no program
    # made, no GPU upload but the network's parameters (at most 1 KB a frame).
    frames.clear()
    sent, exports = _edit(vp, lambda: setattr(mix.inputs[0], "default_value", 0.3))
    assert exports == [("material", "paint")]
    edits = [size for kind, size in sent if kind == "edit"]
    assert len(edits) == 1 and edits[0] < 1500, edits
    valued, frame = vp.frame(view)
    assert all(f.stats["programs_compiled"] + f.stats["programs_loaded"] == 0 for f in frames)
    assert all(f.stats["bytes_uploaded"] == 0 for f in frames), [f.stats["bytes_by_kind"]
                                                                  for f in frames]
    assert 0 < frame.stats["pattern_bytes"] <= 1024
    assert _changed(after, valued).any()
    np.testing.assert_allclose(valued, _fresh(scene, view), atol=2e-3)


def test_hair_added_and_combed_in_the_viewport_is_drawn(viewport):
    """A Curves object (hair) added to the scene appears in the live viewport, and an
    edit of its strands shows: the image equals a fresh export's each time."""
    import bpy
    scene, vp = viewport
    view = _camera_view(scene, bpy.context.evaluated_depsgraph_get())
    before, _ = vp.frame(view)

    def add():
        data = bpy.data.hair_curves.new("Hair")
        data.add_curves([6] * 40)
        for i, point in enumerate(data.points):
            strand, k = divmod(i, 6)
            point.position = (-1.0 + 0.05 * strand, -1.0, 0.25 * k)
            point.radius = 0.02
        scene.collection.objects.link(bpy.data.objects.new("Hair", data))
    _edit(vp, add)
    with_hair, _ = vp.frame(view)
    assert _changed(before, with_hair).sum() > 20
    np.testing.assert_allclose(with_hair, _fresh(scene, view), atol=2e-3)

    def comb():
        data = bpy.data.objects["Hair"].data
        for point in data.points:
            x, y, z = point.position
            point.position = (x + 0.3 * z, y, z)
        data.update_tag()
    _edit(vp, comb)
    combed, _ = vp.frame(view)
    assert _changed(with_hair, combed).any()
    np.testing.assert_allclose(combed, _fresh(scene, view), atol=2e-3)


def test_views_are_progressive_and_send_no_edit(viewport):
    import bpy
    scene, vp = viewport
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view = _camera_view(scene, depsgraph)
    vp.frame(view)
    host = vp.render.host
    before = host.messages
    seen = []
    orbit = view.view.copy()
    orbit[0, 3] += 0.5
    moved = _camera_view(scene, depsgraph)
    moved.view = orbit
    start = time.monotonic()
    channel = host.channel(vp.render.name)
    while time.monotonic() - start < 60:
        vp.render.draw(depsgraph, moved, vp.paint, "medium")
        latest = channel.latest
        if latest is not None and latest.request == channel.requested and \
                (not seen or seen[-1] != latest.number):
            seen.append(latest.number)
            if latest.final:
                break
        time.sleep(0.005)
    kinds = [k for k, s, _ in host.sent_since(before) if s == vp.render.name]
    assert "edit" not in kinds and kinds.count("render") == 1
    presets = [f.preset for f in [channel.latest]]
    assert presets == ["medium"]
    assert len(seen) == 2, seen                  # the interactive frame, then the final one


def test_border_scale_and_orthographic(viewport):
    """A render border renders only its rectangle, equal to that part of the whole
    view; the resolution scale renders fewer pixels over the same rectangle; an
    orthographic view renders."""
    import bpy
    from lantern.addon.viewport import view_request
    scene, vp = viewport
    depsgraph = bpy.context.evaluated_depsgraph_get()
    full, _ = vp.frame(_camera_view(scene, depsgraph))
    bordered = _camera_view(scene, depsgraph, border=(0.25, 0.5, 0.75, 1.0))
    assert bordered.rect == (16, 18, 32, 18) and bordered.size == (32, 18)
    part, frame = vp.frame(bordered)
    assert frame.tag == (16, 18, 32, 18)
    # Ambient occlusion and FXAA see only the rendered rectangle: a few pixels at its
    # edge may differ from the whole view's (FXAA blends an edge pixel differently,
    # by up to a fifth of the image's brightest value: 0.108 of 0.60 here); everything
    # else is that part of it.
    off = np.abs(part - full[0:18, 16:48]).max(axis=-1)
    assert (off > 2e-3).mean() <= 0.01 and off.max() <= 0.25 * full[..., :3].max()
    half = _camera_view(scene, depsgraph, scale=0.5)
    small, _ = vp.frame(half)
    assert small.shape[:2] == (18, 32) and half.rect == (0, 0, W, H)
    from lantern.core.transforms import ortho as orthographic
    ortho = orthographic(-6.0, 6.0, -6.0 * H / W, 6.0 * H / W, 0.1, 100.0)
    flat, _ = vp.frame(view_request((W, H), _camera_view(scene, depsgraph).view, ortho))
    assert flat[..., :3].max() > 0.01


def test_camera_frame_maths():
    """The camera's frame seen through the viewport's window matrix (zoom, offset)."""
    from lantern.addon.viewport import border_in_frame, camera_frame, narrowed
    from lantern.core.transforms import frustum
    camera = frustum(-0.5, 0.5, -0.28, 0.28, 0.1, 100.0)
    assert np.allclose(camera_frame(camera, camera), (0, 0, 1, 1))
    zoomed_out = np.diag([0.5, 0.5, 1.0, 1.0]) @ camera        # the frame inside the region
    assert np.allclose(camera_frame(zoomed_out, camera), (0.25, 0.25, 0.75, 0.75))
    offset = np.eye(4)
    offset[0, 3] = 0.2                                          # panned right by 10 %
    assert np.allclose(camera_frame(offset @ zoomed_out, camera), (0.35, 0.25, 0.85, 0.75))
    assert np.allclose(border_in_frame((0.25, 0.25, 0.75, 0.75), (0, 0.5, 0.5, 1)),
                       (0.25, 0.5, 0.5, 0.75))
    # Narrowing maps the rectangle's corners onto the image's.
    p = narrowed(camera, (0.25, 0.5, 0.75, 1.0))
    corner = np.linalg.inv(camera) @ np.array([0.5 * 2 - 1 - 0.5, 0.0, 0.0, 1.0])
    ndc = p @ corner
    assert np.isclose(ndc[0] / ndc[3], -1.0) and np.isclose(ndc[1] / ndc[3], -1.0)


def test_view_draw_up_to_the_gpu_call(viewport, monkeypatch):
    """RenderEngine.view_draw and view_update, run on a stand-in engine with a plain
    region and view: everything but _paint's `gpu` calls."""
    import bpy
    from lantern.addon import render_engine
    scene, vp = viewport
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = scene.camera.evaluated_get(depsgraph)
    painted, stats = [], []
    monkeypatch.setattr(render_engine, "_paint", lambda engine, sc, *frame: painted.append(frame))
    engine = SimpleNamespace(_viewport=None, _polling=True, update_stats=lambda a, b: stats.append(b),
                             tag_redraw=lambda: None)
    engine._start_polling = lambda: None
    engine.view_update = lambda c, d: render_engine.LanternRenderEngine.view_update(engine, c, d)
    context = SimpleNamespace(
        region=SimpleNamespace(width=W, height=H),
        region_data=SimpleNamespace(view_matrix=camera.matrix_world.inverted(),
                                    window_matrix=camera.calc_matrix_camera(depsgraph, x=W, y=H),
                                    view_perspective='PERSP'),
        space_data=SimpleNamespace(use_render_border=False))
    start = time.monotonic()
    while not painted or not engine._viewport.host.channel(engine._viewport.name).latest.final:
        render_engine.LanternRenderEngine.view_draw(engine, context, depsgraph)
        assert time.monotonic() - start < 60
        time.sleep(0.01)
    number, pixels, rect = painted[-1]
    assert pixels.shape == (H, W, 4) and rect == (0, 0, W, H) and pixels[..., :3].max() > 0.01
    assert stats[-1] in ("", "Lantern: refining")
    reported = []
    engine.report = lambda kind, message: reported.append((kind, message))
    engine._viewport.notices.append("Lantern: a failure")
    render_engine.LanternRenderEngine.view_draw(engine, context, depsgraph)
    assert reported == [({'ERROR'}, "Lantern: a failure")] and not engine._viewport.notices
    # The statistics overlay: off by default; on, the latest frame's line (blf stands in).
    from lantern.addon import viewport_stats
    drawn = []
    monkeypatch.setattr(viewport_stats, "draw_stats", lambda frame, height, scale: drawn.append(
        (viewport_stats.stats_line(frame), height, scale)))
    render_engine.LanternRenderEngine.view_draw(engine, context, depsgraph)
    assert drawn == []
    scene.lantern.viewport_stats = True
    context.preferences = SimpleNamespace(system=SimpleNamespace(ui_scale=1.5))
    render_engine.LanternRenderEngine.view_draw(engine, context, depsgraph)
    (line, height, scale), = drawn
    assert height == H and scale == 1.5 and f"{W}x{H}" in line and " ms" in line
    draws = int(line.split(" draw calls")[0].rsplit(" ", 1)[1])
    assert draws == engine._viewport.shown.stats["draw_calls"] > 0
    assert "GPU" in line or not engine._viewport.shown.gpu_timings
    scene.lantern.viewport_stats = False
    engine._viewport.close()


def test_a_killed_engine_restarts_on_the_next_redraw(viewport):
    import bpy
    scene, vp = viewport
    view = _camera_view(scene, bpy.context.evaluated_depsgraph_get())
    first, _ = vp.frame(view)
    host = vp.render.host
    generation = host.generation
    host.kill()
    deadline = time.monotonic() + 10
    while host.running() and time.monotonic() < deadline:
        time.sleep(0.01)
    again, _ = vp.frame(view)
    assert host.generation == generation + 1
    assert vp.render.notices == ["Lantern: the engine process stopped (killed by SIGKILL); "
                                 "it starts again"]
    np.testing.assert_allclose(again, first, atol=1e-6)


def test_the_redraw_timer_and_pass_registration(viewport):
    """RenderEngine._poll (the redraw timer: a redraw per new frame, stopping once
    nothing is to come) and update_render_passes (Combined and the view layer's
    passes, from core/passes.py), on stand-in engines."""
    import bpy
    from lantern.addon import render_engine
    from lantern.core.passes import PASSES
    scene, vp = viewport
    view = _camera_view(scene, bpy.context.evaluated_depsgraph_get())
    vp.frame(view)
    redraws = []
    engine = SimpleNamespace(_viewport=vp.render, _polling=True,
                             tag_redraw=lambda: redraws.append(1))
    engine._poll = lambda: render_engine.LanternRenderEngine._poll(engine)
    vp.render.host.channel(vp.render.name).fresh = True
    assert render_engine.LanternRenderEngine._poll(engine) is None   # the final frame is in
    assert len(redraws) == 2 and engine._polling is False

    registered = []
    engine = SimpleNamespace(register_pass=lambda *a: registered.append(a[2:]))
    layer = scene.view_layers[0]
    layer.use_pass_z, layer.use_pass_object_index = True, True
    layer.use_pass_cryptomatte_asset = True
    render_engine.LanternRenderEngine.update_render_passes(engine, scene, layer)
    # Under this Blender's names (5.0: Object Index), a matte's three levels.
    assert registered == [("Combined", 4, "RGBA", "COLOR"),
                          ("Depth", 1, "Z", "VALUE"), ("Object Index", 1, "X", "VALUE"),
                          *((f"CryptoAsset0{k}", 4, "RGBA", "COLOR") for k in range(3))]
    titles = {p.title for p in PASSES.values() if p.provided}
    assert all(name in titles for name, *_ in registered[1:])


def test_the_bounce_converges_over_viewport_frames_to_the_stills_image(addon):
    """With Cycles' default bounces the engine host's viewport frames trace the
    irradiance field a ray budget at a time (RenderSettings.progressive_field): it
    renders again, frames not final, until the field converged, and the final frame is
    the still's image."""
    import bpy
    from lantern.engine.gpu.passes.irradiance import BUDGET
    scene = _scene()
    scene.cycles.max_bounces = 12
    vp = Viewport()
    try:
        view = _camera_view(scene, bpy.context.evaluated_depsgraph_get())
        channel = vp.render.host.channel(vp.render.name)
        frames = []

        class Recorded(type(channel.event)):
            def set(self):          # on the reader thread, as each frame arrives
                if channel.latest is not None:
                    frames.append(channel.latest)
                super().set()
        channel.event = Recorded()
        after, frame = vp.frame(view)
    finally:
        vp.close()
    assert frame.stats["field_pending"] == 0 and frame.stats["field_grids"] == 1
    converging = [f for f in frames if f.stats.get("field_pending", 0) > 0]
    assert converging and not any(f.final for f in converging)
    assert max(f.stats.get("field_rays", 0) for f in frames) <= BUDGET["medium"]
    # The still's field: a still adds its final gather, a viewport's frames do not.
    np.testing.assert_allclose(after, _fresh(scene, view, final_gather=False), atol=2e-3)
