"""Light volumes: many shadowless point lights share one instanced draw, and what they
add is exactly the sum of the lights drawn one by one (additive HDR blending)."""
import numpy as np

import shadow_scenes as ss
from lantern.engine import RenderSettings, render_stage
from test_shadows import top_down_camera

POSITIONS = [(x, y, 0.4) for x in (-2.4, -0.8, 0.8, 2.4) for y in (-2.4, -0.8, 0.8, 2.4)]


def _render(lights, shadow=False):
    stage = ss.new_stage()
    ss.add_box(stage, center=(0.3, 0.2, 0.5))
    for i, pos in enumerate(lights):
        ss.add_light(stage, "point", shadow=shadow, pos=pos, power=0.5, radius=0.05,
                     name=f"point_{i:02d}")
    top_down_camera(stage, 8.0)
    # FXAA is not additive: compare the light's sums without it.
    return render_stage(stage, RenderSettings(width=64, height=64, fxaa=False,
                                              lighting="volumes", compute=False))


def test_batched_lights_equal_the_sum_of_single_lights():
    together = _render(POSITIONS)
    assert together.stats["batched_lights"] == len(POSITIONS)
    assert together.stats["draw_calls"] >= 1
    alone = sum(_render([pos]).rgba[..., :3] for pos in POSITIONS)
    lit = alone > 1e-3
    # Each additive blend into the float16 HDR target rounds by up to one
    # half-precision step (2^-10 relative): one step per light at most.
    assert np.allclose(together.rgba[..., :3][lit], alone[lit],
                       rtol=len(POSITIONS) * 2.0 ** -10, atol=2e-4)
    assert np.all(together.rgba[..., :3][~lit] < 2e-3)


def test_shadow_casting_lights_take_the_stencil_path():
    result = _render(POSITIONS[:3], shadow=True)
    assert result.stats.get("batched_lights", 0) == 0
    assert result.stats["stencil_marks"] == 3 and result.stats["shadow_maps"] == 3


def test_a_preset_change_repacks_the_light_table_only_for_disk_lights():
    """The presets differ in a disk light's polygon: moving between a viewport's
    interactive preset and the scene's re-uploads the light table only where a disk
    light is drawn with it."""
    import numpy as np
    from lantern.core.lights import DISK, SUN
    from lantern.engine.gpu.lights import LightTable
    from lantern.engine.scene import Light, Scene

    class Uploads:
        def __init__(self):
            self.writes = 0

        def rewrite_float_texture(self, texture, data, kind):
            self.writes += 1
            return "texture"

        def write_texture(self, *args, **kwargs):
            self.writes += 1

    for kinds, repacked in (((SUN,), 0), ((SUN, DISK), 1)):
        scene = Scene(lights={f"/{k}": Light(kind=k, name=k, color=np.ones(3), radius=0.5)
                              for k in kinds})
        uploads = Uploads()
        table = LightTable(uploads)
        table.update(scene, set(scene.lights), 16)
        table.update(scene, set(), 32)
        table.update(scene, set(), 16)
        assert uploads.writes - 1 == 2 * repacked, kinds


def test_the_light_table_packs_each_light_as_it_would_alone():
    """The table's rows are filled a column at a time for all lights: each row is the
    one its light gets packed alone, and holds the light's own numbers."""
    import math
    from lantern.core.lights import DISK, POINT, RECT, SPOT, SUN
    from lantern.engine.gpu.lights import pack_rows
    from lantern.engine.lighting import headlight
    from lantern.engine.scene import Light

    rng = np.random.default_rng(3)
    lights = [headlight()]
    for i, kind in enumerate([POINT, SPOT, SUN, RECT, DISK] * 3):
        lights.append(Light(kind=kind, name=f"/{kind}{i}", color=rng.uniform(0, 5, 3),
                            position=rng.uniform(-1e4, 1e4, 3), axis=rng.normal(size=3),
                            x_axis=np.array([1.0, 0, 0]), y_axis=np.array([0, 1.0, 0]),
                            radius=float(rng.uniform(0, 1)), width=1.5, height=0.5,
                            cone_angle=float(rng.uniform(5, 200)), soft_falloff=bool(i % 2),
                            diffuse=0.5, specular=2.0))
    ranges = rng.uniform(1, 20, len(lights))
    rows = pack_rows(lights, ranges, 16)
    for row, light, reach in zip(rows, lights, ranges):
        assert np.array_equal(row, pack_rows([light], [reach], 16)[0]), light.name
        assert np.allclose(row[0, :3].astype(np.float64) + row[7, :3], light.position, rtol=1e-12)
        assert row[0, 3] == np.float32(reach)
        assert np.array_equal(row[1, :3], light.color.astype(np.float32))
        assert np.allclose(row[2, :3], light.direction, atol=1e-7)
        assert row[2, 3] == np.float32(math.cos(math.radians(min(light.cone_angle, 180.0))))
        assert row[6, 0] == {RECT: 4, DISK: 16}.get(light.kind, 0)
