"""The engine host starts before the first F12 (addon/prestart.py) and warms its
programs up (engine/host/warmup.py): the first F12 of Blender's default scene then
makes no program."""
import pytest


@pytest.fixture(scope="module")
def addon():
    import lantern
    lantern.register()
    yield
    lantern.unregister()


def test_loading_a_file_that_renders_with_lantern_starts_the_warm_host(addon, tmp_path):
    import bpy
    from lantern.addon import host, scene_render
    bpy.ops.wm.read_factory_settings()          # Blender's default scene: cube, light, camera
    scene = bpy.context.scene
    scene.render.engine = 'LANTERN'
    scene.render.resolution_x, scene.render.resolution_y = 64, 36
    scene.render.resolution_percentage = 100
    blend = tmp_path / "default.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    scene_render.shutdown()
    assert not host.get().running()

    bpy.ops.wm.open_mainfile(filepath=str(blend))
    engine_host = host.get()
    assert engine_host.running(), "no engine host after loading a file that uses Lantern"
    generation = engine_host.generation

    bpy.ops.render.render()
    scene = bpy.context.scene
    name = f"render:{scene.name_full}:{bpy.context.view_layer.name}"
    frame = engine_host.channels[name].latest
    assert frame is not None and engine_host.generation == generation
    assert frame.stats["programs_compiled"] == 0, frame.stats
    assert frame.stats["programs_loaded"] == 0, "the warm-up left programs to the first F12"


def test_no_host_for_a_file_that_renders_with_another_engine(addon, tmp_path):
    import bpy
    from lantern.addon import host, scene_render
    bpy.ops.wm.read_factory_settings()
    bpy.context.scene.render.engine = 'CYCLES'
    blend = tmp_path / "cycles.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    scene_render.shutdown()
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    assert not host.get().running()
