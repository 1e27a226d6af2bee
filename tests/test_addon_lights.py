"""Lantern's light settings (shadow resolution and bias on `light.lantern`) reach the
stage as `lantern:shadowResolution` / `lantern:shadowBias`, from F12's in-memory export
and from `lantern export`, which never registers the add-on."""
import subprocess
import sys

import bpy
import pytest
from pxr import Usd

from _export_helpers import export_current


@pytest.fixture
def addon():
    import lantern
    lantern.register()
    yield
    lantern.unregister()


def _light(name, kind, use_shadow=True, resolution=None, bias=None):
    light = bpy.data.lights.new(name, kind)
    light.use_shadow = use_shadow
    if resolution is not None:
        light.lantern.shadow_resolution = resolution
    if bias is not None:
        light.lantern.shadow_bias = bias
    bpy.context.scene.collection.objects.link(bpy.data.objects.new(name, light))


def _lights_scene():
    _light("Spot", "SPOT", resolution=2048, bias=2.5)
    _light("Sun", "SUN", resolution=512, bias=0.25)
    _light("Point", "POINT")                                    # defaults: nothing authored
    _light("Area", "AREA", use_shadow=False, resolution=4096, bias=3.0)  # casts no shadow


def _shadow_attributes(stage, name):
    prim = stage.GetPrimAtPath(f"/root/{name}")
    return {attr: prim.GetAttribute(attr).Get()
            for attr in ("lantern:shadowResolution", "lantern:shadowBias")
            if prim.GetAttribute(attr).HasAuthoredValue()}


def _check(stage):
    assert _shadow_attributes(stage, "Spot") == {"lantern:shadowResolution": 2048,
                                                 "lantern:shadowBias": 2.5}
    assert _shadow_attributes(stage, "Sun") == {"lantern:shadowResolution": 512,
                                                "lantern:shadowBias": 0.25}
    assert _shadow_attributes(stage, "Point") == {}
    assert _shadow_attributes(stage, "Area") == {}


def test_light_settings_are_exported(addon, empty_scene):
    _lights_scene()
    stage, _ = export_current()
    _check(stage)


def test_lantern_export_reads_them_without_the_addon(addon, empty_scene, tmp_path):
    _lights_scene()
    blend = tmp_path / "lights.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "lights.usda"
    proc = subprocess.run([sys.executable, "-m", "lantern", "export", str(blend), "-o", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    _check(Usd.Stage.Open(str(out)))
