"""Live exports (exporters/live.py, addon/live.py): each kind of edit, turned from real
depsgraph updates into the partial export it calls for, leaves the mirror stage
exactly as a fresh export of the edited scene writes it (partial exports write what
the full one does, with its gatherers and writers), and sends only what changed."""
import numpy as np
import pytest
from pxr import Usd

from test_viewport import _rig


def _scene():
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 10
    bpy.ops.mesh.primitive_cube_add(location=(-2.0, 0.0, 0.0))
    cube = bpy.context.object
    material = bpy.data.materials.new("paint")
    cube.data.materials.append(material)
    bpy.ops.mesh.primitive_cube_add(location=(2.0, 0.0, 0.0))
    twin = bpy.data.objects.new("Twin", bpy.context.object.data)   # shares its mesh
    scene.collection.objects.link(twin)
    twin.location = (2.0, 3.0, 0.0)
    bpy.data.objects.new("Empty", None)
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -8.0, 2.0)
    for ob in (lamp, camera):
        scene.collection.objects.link(ob)
    scene.camera = camera
    scene.world = bpy.data.worlds.new("World")     # with a Background node
    _rig(scene)
    scene.frame_set(1)
    return scene


class Synced:
    def __init__(self):
        import bpy
        from lantern.addon.live import LiveScene
        self.live = LiveScene()
        self.fragments = []
        self.handlers = (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post)
        for handlers in self.handlers:
            handlers.append(self.on_update)
        self.on_update(None, bpy.context.evaluated_depsgraph_get())

    def on_update(self, scene, depsgraph):
        fragment = self.live.sync(depsgraph)
        self.fragments.append((list(self.live.last), fragment))

    def close(self):
        for handlers in self.handlers:
            handlers.remove(self.on_update)
        self.live.close()


def _fresh():
    import bpy
    from lantern.exporters.live import export_live
    stage = Usd.Stage.CreateInMemory()
    export_live(bpy.context.evaluated_depsgraph_get(), stage, lambda m: None)
    return stage.GetRootLayer().ExportToString()


def _set(collection, name, attribute, value):
    import bpy
    setattr(getattr(bpy.data, collection)[name], attribute, value)


def _pose():
    import bpy
    bone = bpy.data.objects["Rig"].pose.bones["B1"]
    bone.rotation_mode = "XYZ"
    bone.rotation_euler = (0.0, 0.4, 0.0)


def _lift():
    import bpy
    mesh = bpy.data.objects["Cube"].data
    mesh.vertices[0].co.z += 0.3
    mesh.update()


def _lift_shared():
    import bpy
    mesh = bpy.data.objects["Twin"].data
    mesh.vertices[0].co.z += 0.3
    mesh.update()


def _new_material():
    import bpy
    bpy.data.objects["Cube"].data.materials[0] = bpy.data.materials.new("other")


def _subsurf():
    import bpy
    bpy.data.objects["Cube"].modifiers.new("Subdivision", "SUBSURF")


def _bsdf():
    import bpy
    node = bpy.data.materials["paint"].node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (0.1, 0.2, 0.9, 1.0)


def _world():
    import bpy
    world = bpy.data.worlds["World"]
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.1, 0.0, 1.0)


def _spot():
    import bpy
    bpy.data.objects["Lamp"].data.type = "SPOT"


def _add():
    import bpy
    bpy.ops.mesh.primitive_uv_sphere_add(location=(0.0, 4.0, 0.0))


def _delete():
    import bpy
    bpy.data.objects.remove(bpy.data.objects["Twin"])


def _reparent():
    import bpy
    bpy.data.objects["Lamp"].parent = bpy.data.objects["Cube"]


def _frame():
    import bpy
    bpy.context.scene.frame_set(7)


CASES = {
    "move": (lambda: _set("objects", "Cube", "location", (-2.0, 1.0, 0.5)), {"object"}),
    "pass index": (lambda: _set("objects", "Cube", "pass_index", 4), {"object"}),
    "light power": (lambda: _set("lights", "Lamp", "energy", 250.0), {"data"}),
    "light type": (_spot, {"data"}),
    "camera lens": (lambda: _set("cameras", "Camera", "lens", 35.0), {"data"}),
    "mesh edit": (_lift, {"geometry", "object"}),
    "shared mesh edit": (_lift_shared, {"geometry", "object"}),
    "modifier": (_subsurf, {"geometry", "object"}),
    "material": (_bsdf, {"material", "object"}),
    "world": (_world, {"world"}),
    "pose": (_pose, {"pose"}),
    "frame": (_frame, {"pose", "object"}),
    "new material": (_new_material, {"object", "scene"}),
    "add": (_add, {"scene"}),
    "delete": (_delete, {"scene"}),
    "reparent": (_reparent, {"scene"}),
    "rename": (lambda: _set("objects", "Cube", "name", "Box"), {"scene"}),
}


@pytest.mark.parametrize("case", CASES)
def test_a_partial_export_writes_what_a_full_export_writes(empty_scene, case):
    import bpy
    action, kinds = CASES[case]
    _scene()
    synced = Synced()
    try:
        synced.fragments.clear()
        action()
        bpy.context.view_layer.update()
        done = {kind for exports, _ in synced.fragments for kind, _ in exports}
        assert done and done <= kinds, (done, kinds)
        sent = [f for _, f in synced.fragments if f is not None]
        assert sent, "the edit sent nothing"
        assert synced.live.mirror.stage.GetRootLayer().ExportToString() == _fresh()
    finally:
        synced.close()


def test_a_move_sends_one_transform_among_many(empty_scene):
    """Independent of the scene's size: moving one of 200 objects exports one object
    and sends its translate alone."""
    import bpy
    from _export_helpers import CUBE_FACES, CUBE_VERTS
    # 20 cm cubes Cube, Cube.001, ... made through bpy.data, each with its own mesh:
    # 200 calls of the operator, each updating the whole scene, made this test 5x slower.
    corners = [(0.1 * x, 0.1 * y, 0.1 * z) for x, y, z in CUBE_VERTS]
    for i in range(200):
        mesh = bpy.data.meshes.new("Cube")
        mesh.from_pydata(corners, [], CUBE_FACES)
        cube = bpy.data.objects.new("Cube", mesh)
        cube.location = (i % 20, i // 20, 0.0)
        bpy.context.scene.collection.objects.link(cube)
    bpy.context.view_layer.update()
    synced = Synced()
    try:
        synced.fragments.clear()
        bpy.data.objects["Cube.100"].location.z = 2.0
        bpy.context.view_layer.update()
        (exports, fragment), = synced.fragments
        assert exports == [("object", "Cube.100")]
        assert fragment["copy"] == ["/root/Cube_100.xformOp:translate"] and not fragment["arrays"]
        assert np.isclose(synced.live.mirror.stage.GetAttributeAtPath(
            "/root/Cube_100.xformOp:translate").Get()[2], 2.0)
    finally:
        synced.close()


def test_blend_shape_weights_at_a_new_frame(corpus):
    """Animated shape keys (on a rig, and on a mesh holding its blend shapes with a
    one-joint skeleton): a frame change sends SkelAnimation channels and blend-shape
    weights only, and a Session fed the fragments draws what a fresh export draws,
    re-reading no mesh."""
    import bpy
    from lantern.engine import RenderSettings, Session
    from lantern.engine.usd.fragments import apply, receiver
    from lantern.exporters import open_blend
    open_blend(str(corpus / "blender" / "28_shapekeys_anim.blend"))
    scene = bpy.context.scene
    scene.frame_set(scene.frame_start)
    synced = Synced()
    host_stage = receiver()
    try:
        for _, fragment in synced.fragments:
            apply(host_stage, fragment)
        # One sample a pixel: the shapes' motion, not the pixel filter's spread of it.
        settings = RenderSettings(width=48, height=32, supersample=1)
        with Session(host_stage, settings) as session:
            before = session.render()
            synced.fragments.clear()
            scene.frame_set(scene.frame_start + (scene.frame_end - scene.frame_start) // 2)
            (exports, fragment), = [(e, f) for e, f in synced.fragments if f is not None]
            assert {kind for kind, _ in exports} == {"pose"}
            names = [p.rsplit(".", 1)[1] for p in fragment["copy"]]
            assert all(p.split(".")[0].endswith("/Animation") for p in fragment["copy"])
            assert "blendShapeWeights" in names and set(names) <= {
                "blendShapeWeights", "translations", "rotations", "scales"}
            apply(host_stage, fragment)
            live = session.render()
        fresh = Usd.Stage.CreateInMemory()
        fresh.GetRootLayer().ImportFromString(_fresh())
        with Session(fresh, settings) as session:
            expected = session.render()
        assert live.stats["meshes_uploaded"] == 0 and live.stats["prims_read"] <= 4
        np.testing.assert_allclose(live.rgba, expected.rgba, atol=1e-5)
        assert np.abs(live.rgba - before.rgba).max() > 1e-2     # the shapes moved
    finally:
        synced.close()


def test_a_viewport_edit_of_a_subdivided_mesh_sends_its_cage(empty_scene, monkeypatch):
    """With Lantern > Subdivision on Cage, a mesh whose only modifier is its Subdivision
    Surface is exported as its cage, and moving one of its vertices in the viewport sends
    the cage's points (507 for Suzanne), not the level-2 mesh's 7,958; the mirror then
    equals a fresh cage export. With Apply, the same edit sends the refined mesh."""
    import bpy
    import lantern.addon.live as addon_live
    from lantern.exporters.live import export_live

    sent = {}
    for option in ("cage", "apply"):
        monkeypatch.setattr(addon_live, "subdivision_option", lambda scene: option)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.mesh.primitive_monkey_add()
        ob = bpy.context.object
        ob.modifiers.new("Subdivision", "SUBSURF").levels = 2
        synced = Synced()
        try:
            synced.fragments.clear()
            ob.data.vertices[0].co.z += 0.3
            ob.data.update()
            bpy.context.view_layer.update()
            done = [kind for exports, _ in synced.fragments for kind, _ in exports]
            assert done and "scene" not in done, done       # a partial export
            arrays = [a for _, f in synced.fragments if f for a in f["arrays"]]
            points = [a for path, _, _, a in arrays if path.endswith(".points")]
            assert len(points) == 1
            sent[option] = len(points[0])
            if option == "cage":
                fresh = Usd.Stage.CreateInMemory()
                export_live(bpy.context.evaluated_depsgraph_get(), fresh, lambda m: None, "cage")
                assert synced.live.mirror.stage.GetRootLayer().ExportToString() == \
                    fresh.GetRootLayer().ExportToString()
                mesh = next(p for p in fresh.Traverse() if p.GetTypeName() == "Mesh")
                assert mesh.GetAttribute("subdivisionScheme").Get() == "catmullClark"
        finally:
            synced.close()
    assert sent == {"cage": 507, "apply": 7958}


def test_f12_exports_cages_when_lantern_subdivides(empty_scene, monkeypatch):
    """F12's export (StillScene) follows Lantern > Subdivision too: Cage writes the
    cage with its rules, Apply the modifier's mesh."""
    import bpy
    import lantern.addon.live as addon_live

    bpy.ops.mesh.primitive_monkey_add()
    bpy.context.object.modifiers.new("Subdivision", "SUBSURF").render_levels = 2
    counts = {}
    for option in ("cage", "apply"):
        monkeypatch.setattr(addon_live, "subdivision_option", lambda scene: option)
        still = addon_live.StillScene()
        try:
            still.sync(bpy.context.evaluated_depsgraph_get())
            mesh = next(p for p in still.mirror.stage.Traverse() if p.GetTypeName() == "Mesh")
            counts[option] = (len(mesh.GetAttribute("points").Get()),
                              mesh.GetAttribute("subdivisionScheme").Get())
        finally:
            still.close()
    assert counts["cage"] == (507, "catmullClark")
    assert counts["apply"][0] > 507 and counts["apply"][1] != "catmullClark"


def test_an_edit_inside_a_node_group_reaches_the_material(empty_scene):
    """The material's Principled BSDF sits in a node group: changing a value inside the
    group exports that material again, as a full export would write it."""
    import bpy
    _scene()
    group = bpy.data.node_groups.new("Shading", "ShaderNodeTree")
    group.interface.new_socket(name="BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    inner = group.nodes.new("ShaderNodeBsdfPrincipled")
    group.links.new(inner.outputs["BSDF"], group.nodes.new("NodeGroupOutput").inputs["BSDF"])
    tree = bpy.data.materials["paint"].node_tree
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    tree.links.new(node.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    bpy.context.view_layer.update()
    synced = Synced()
    try:
        synced.fragments.clear()
        inner.inputs["Base Color"].default_value = (0.1, 0.7, 0.2, 1.0)
        bpy.context.view_layer.update()
        done = {kind for exports, _ in synced.fragments for kind, _ in exports}
        assert "material" in done, synced.fragments
        assert synced.live.mirror.stage.GetRootLayer().ExportToString() == _fresh()
    finally:
        synced.close()
