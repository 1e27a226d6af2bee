"""The engine host starts before the first F12 (addon/prestart.py) and warms its
programs up (engine/host/warmup.py): the first F12 of Blender's default scene then
makes no program, and the textured, rigged demo asks for none the warm-up did not."""
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
    # The suite expects the CPU (conftest.py), and the host inherits that: no warning.
    assert not any("rendering on the CPU" in w for w in frame.warnings), frame.warnings


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


def test_the_warm_up_makes_every_program_of_the_textured_rigged_demo(tmp_path, monkeypatch):
    """Not only the default scene's: the demo (image textures, a normal map, a rig, a
    sun, area and point lights), exported as F12 exports it (its Suzanne subdivided by
    Blender, the render panel's default), asks for no program the warm-up did not."""
    import bpy
    from lantern.engine import RenderSettings, render_stage
    from lantern.engine.gpu import programs
    from lantern.engine.host.warmup import warm
    from lantern.exporters import ExportOptions, stage_from_depsgraph
    from reference_scenes import build_demo
    build_demo(str(tmp_path))
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get(),
                                    ExportOptions(subdivision="apply"))
    asked = []
    get = programs.ProgramCache.get

    def recorded(self, *args, **kwargs):
        program = get(self, *args, **kwargs)
        asked.append(program.extra)
        return program
    monkeypatch.setattr(programs.ProgramCache, "get", recorded)
    warm(["medium"])
    warmed = set(asked)
    asked.clear()
    render_stage(stage, RenderSettings(width=64, height=36, preset="medium"))
    assert asked and set(asked) <= warmed, [key[:3] for key in set(asked) - warmed]
