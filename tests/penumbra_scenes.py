"""Area-light penumbrae (docs/rendering.md): scenes lit by one area light only, shared by the
Cycles reference script (references/make_cycles_references.py penumbra, point-sampled
like the box set: they measure light, not edges) and the tests.

- rect, disk: a white unit box on the white plane (calibration.build_box_scene's
  scene) under a large area light behind it, so its soft shadow falls towards the
  camera: a 2 x 1 m rectangle (an anisotropic penumbra) and a 1.6 m disk;
- demo: Lantern's demo at frame 13 with only its area light (`Panel`, 2 m square)
  and a black world: the scene measured "2.1-2.7x too bright" before the shading work in its
  penumbra.

`penumbra(image, cycles, unshadowed)` is the measurement: the pixels Cycles shades
between 10% and 90% of the unshadowed light (the penumbra), and the ratio of the
image's light to Cycles' there. `roughness(image, mask, unshadowed)` is the penumbra's
high-frequency energy: a dither shows there, a smooth penumbra (Cycles') has little."""
import numpy as np
from scipy.ndimage import gaussian_filter

import calibration

SIZE = (128, 72)
LIGHTS = {
    "rect": dict(shape='RECTANGLE', size=2.0, size_y=1.0, energy=150.0,
                 location=(-1.3, 1.1, 2.2), target=(0.0, 0.0, 0.3)),
    "disk": dict(shape='DISK', size=1.6, energy=150.0,
                 location=(-1.5, 0.5, 1.9), target=(0.0, 0.0, 0.3)),
}
SCENES = ("rect", "disk", "demo")


def _area_light(scene, name, spec):
    import bpy
    from mathutils import Vector
    data = bpy.data.lights.new(name, 'AREA')
    data.shape, data.size, data.energy = spec["shape"], spec["size"], spec["energy"]
    if "size_y" in spec:
        data.size_y = spec["size_y"]
    data.use_shadow = True
    light = bpy.data.objects.new(name, data)
    light.location = spec["location"]
    light.rotation_euler = (Vector(spec["target"]) - light.location).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(light)
    return light


def build(name, workdir="/tmp/lantern-penumbra"):
    """The scene `name` of SCENES, current in this Blender session."""
    import bpy
    if name == "demo":
        import os
        from lantern.demo.build_scene import build as build_demo
        os.makedirs(workdir, exist_ok=True)
        build_demo(os.path.join(workdir, "demo.blend"))
        scene = bpy.context.scene
        for ob in [o for o in scene.objects if o.type == 'LIGHT' and o.name != "Panel"]:
            bpy.data.objects.remove(ob)
        scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
        scene.frame_set(13)
    else:
        scene = calibration.build_box_scene("sun")
        bpy.data.objects.remove(bpy.data.objects["sun"])
        _area_light(scene, name, LIGHTS[name])
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    return scene


def penumbra(image, cycles, unshadowed, lo=0.1, hi=0.9):
    """(mask, ratio): Cycles' penumbra pixels (visibility between lo and hi of the
    unshadowed radiance, where that is not dark) and sum(image) / sum(cycles) there."""
    u = unshadowed[..., :3].mean(-1)
    c = cycles[..., :3].mean(-1)
    v = c / np.maximum(u, 1e-9)
    mask = (u > 0.05 * np.percentile(u, 99)) & (v > lo) & (v < hi)
    ratio = float(image[..., :3].mean(-1)[mask].sum() / max(c[mask].sum(), 1e-12))
    return mask, ratio



def roughness(image, mask, unshadowed, sigma=1.0):
    """The penumbra's high-frequency energy: the RMS of the luminance less its Gaussian
    blur (sigma in pixels), over its mean, on the pixels of `mask` where the unshadowed
    image is itself smooth (no geometric edge or texture: only the shadow varies)."""
    def detail(rgba):
        lum = rgba[..., :3].mean(-1)
        return lum, lum - gaussian_filter(lum, sigma)
    lum_u, detail_u = detail(unshadowed)
    flat = mask & (np.abs(detail_u) < 0.02 * lum_u.mean())
    lum, d = detail(image)
    return float(np.sqrt((d[flat] ** 2).mean()) / lum[flat].mean()), int(flat.sum())
