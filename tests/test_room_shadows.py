"""A closed room with the sun outside (docs/rendering.md, "Shadow seams"): no direct
light gets in, whether its walls are planes of zero thickness (single- or double-sided)
or boxes, each wall a mesh of its own meeting the others at seams. A depth bias and a
filter that reaches past an occluder's edge once let the sun through every seam as a
line of bright dots, up to 0.57 of a sunlit surface (shaders/shadow_lookup.glsl,
contact_shadow). Black is below 1e-4 of a sunlit white surface's radiance (stricter
than 1e-4 of the sun's own). The same room with a window still lights its floor patch
in full."""
import math

import numpy as np
import pytest
from pxr import Gf, UsdGeom

import shadow_scenes as ss
from lantern.engine import RenderSettings, render_stage

STRENGTH = 3.0
SUNLIT = STRENGTH / math.pi        # a white Lambert surface facing the sun
HALF, HEIGHT = (2.0, 1.5), 2.5     # shadow_scenes.add_room's default room
WALLS = {"planes": dict(thickness=0.0, double_sided=False),
         "double-sided planes": dict(thickness=0.0, double_sided=True),
         "boxes": dict(thickness=0.2)}


def sun_direction(elevation, azimuth):
    """The direction the sun's light travels, from a sun at that elevation and azimuth."""
    e, a = math.radians(elevation), math.radians(azimuth)
    return np.array([-math.cos(e) * math.cos(a), -math.cos(e) * math.sin(a), -math.sin(e)])


def render(stage, width, height):
    result = render_stage(stage, RenderSettings(width=width, height=height, preset="medium",
                                                fxaa=False, supersample=1))
    assert result.stats["shadow_maps"] == 1
    return result.rgba[..., :3]


@pytest.mark.parametrize("walls", sorted(WALLS))
@pytest.mark.parametrize("elevation, azimuth", [(5.0, 30.0), (85.0, 200.0)])
def test_a_closed_room_is_black_inside(walls, elevation, azimuth):
    """A camera in a corner sees the floor, the ceiling, three walls and their seams;
    the sun grazes the room (5 deg) or stands almost over it (85 deg)."""
    stage = ss.new_stage(None)
    ss.add_room(stage, half=HALF, height=HEIGHT, **WALLS[walls])
    ss.add_light(stage, "sun", dir=tuple(sun_direction(elevation, azimuth)), strength=STRENGTH)
    ss.add_camera(stage, eye=(-1.6, -1.2, 1.6), target=(1.5, 1.2, 0.8), focal=14.0)
    image = render(stage, 160, 90).max(axis=-1) / SUNLIT
    print(f"{walls}, sun at {elevation} deg: brightest {image.max():.2e} of a sunlit "
          f"surface, {int((image >= 1e-4).sum())} pixels at 1e-4 or more")
    assert image.max() < 1e-4


def test_a_window_lights_its_patch_of_floor_in_full():
    """Seen from under the ceiling, straight down: the floor points whose ray to the sun
    passes through the window (numpy) are lit as a sunlit floor is, the rest black."""
    window = (-0.6, 0.6, 0.8, 1.8)     # x0, x1, z0, z1 in the +Y wall
    elevation, azimuth = 45.0, 75.0
    w, h = 128, 96                     # 4 x 3 m: the room's floor, 3.1 cm a pixel
    stage = ss.new_stage(None)
    ss.add_room(stage, half=HALF, height=HEIGHT, window=window)
    direction = sun_direction(elevation, azimuth)
    ss.add_light(stage, "sun", dir=tuple(direction), strength=STRENGTH)
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    cam.CreateHorizontalApertureAttr(2 * HALF[0] * 10)
    cam.CreateVerticalApertureAttr(2 * HALF[1] * 10)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.05, 10.0))
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, 0, HEIGHT - 0.1), Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 1, 0))
    cam.AddTransformOp().Set(m.GetInverse())
    image = render(stage, w, h)[..., 0] / SUNLIT

    x = ((np.arange(w) + 0.5) / w - 0.5) * 2 * HALF[0]
    y = (0.5 - (np.arange(h) + 0.5) / h) * 2 * HALF[1]
    X, Y = np.meshgrid(x, y)
    t = (HALF[1] - Y) / -direction[1]              # along the ray to the sun, to the wall
    wx, wz = X - direction[0] * t, -direction[2] * t
    lit = (wx > window[0]) & (wx < window[1]) & (wz > window[2]) & (wz < window[3])
    edge = np.zeros_like(lit)
    for dy in range(-2, 3):
        for dx in range(-2, 3):
            edge |= np.roll(np.roll(lit, dy, 0), dx, 1) != lit
    expected = math.sin(math.radians(elevation))  # the floor's cosine to the sun
    inside, outside = lit & ~edge, ~lit & ~edge
    print(f"patch: {int(inside.sum())} px, light {image[inside].min():.4f}..{image[inside].max():.4f} "
          f"of {expected:.4f}; elsewhere at most {image[outside].max():.2e}")
    assert inside.sum() > 300
    assert np.abs(image[inside] / expected - 1.0).max() < 0.01
    assert image[outside].max() < 1e-4
