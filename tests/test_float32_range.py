"""Values a double holds and float32 does not (|v| > 3.4e38, e.g. 1e300): the GPU's
tables are float32, where such a value becomes Inf. The stage reader refuses them as
it refuses NaN and Inf: one warning naming the prim, and the prim is left out; no
numpy overflow warning escapes the render.

One case per kind of value: a light's position, a mesh's transform, its points, its
primvar (double-typed attributes, which USD keeps as authored)."""
import warnings

import numpy as np
import pytest
from pxr import Sdf, UsdGeom, UsdLux, Vt

from lantern.engine import RenderSettings, render_stage
from lantern.engine.usd.stage import StageReader

import shadow_scenes as S  # tests/ is on sys.path (conftest.py)

HUGE = 1e300              # finite in double, Inf in float32
TRI = "/root/tri"


def _scene():
    stage = S.new_stage(half=2.0)
    S.add_light(stage, "point", pos=(0.0, 0.0, 1.0), power=10.0, radius=0.0, shadow=False)
    S.add_camera(stage, (0.0, -4.0, 3.0), (0.0, 0.0, 0.0))
    return stage


def _triangle(stage, points=((0, 0, 0.1), (1, 0, 0.1), (0, 1, 0.1)), st=None):
    """A triangle whose points (and st, when given) are authored as doubles."""
    mesh = UsdGeom.Mesh.Define(stage, TRI)
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    # The schema's points are point3f[]: a file may author point3d[], which USD keeps
    # (through Sdf: Usd would author the schema's type).
    spec = stage.GetRootLayer().GetPrimAtPath(TRI)
    Sdf.AttributeSpec(spec, "points", Sdf.ValueTypeNames.Point3dArray).default = \
        Vt.Vec3dArray(list(points))
    if st is not None:
        UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2dArray, UsdGeom.Tokens.vertex).Set(list(st))
    return mesh


def _huge_light(stage):
    light = UsdLux.SphereLight.Define(stage, "/root/huge")
    light.CreateIntensityAttr(1.0)
    light.AddTranslateOp().Set((HUGE, 0.0, 0.0))
    return "/root/huge"


def _huge_transform(stage):
    _triangle(stage).AddTranslateOp().Set((0.0, HUGE, 0.0))
    return TRI


def _huge_point(stage):
    _triangle(stage, points=((0, 0, 0.1), (HUGE, 0, 0.1), (0, 1, 0.1)))
    return TRI


def _huge_primvar(stage):
    _triangle(stage, st=((0, 0), (HUGE, 0), (0, 1)))
    return TRI


def _drawn(scene):
    return set(scene.lights) | set(scene.instances)


@pytest.mark.parametrize("make", [_huge_light, _huge_transform, _huge_point, _huge_primvar],
                         ids=["light", "transform", "points", "primvar"])
def test_a_value_beyond_float32_leaves_its_prim_out_with_one_warning(make):
    stage = _scene()
    path = make(stage)
    reader = StageReader(stage)
    reader.sync(None)
    assert path not in _drawn(reader.scene)
    assert "/root/plane" in reader.scene.instances          # the rest is read
    reader.close()

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = render_stage(stage, RenderSettings(width=32, height=18, fxaa=False, ambient_occlusion=False))
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], \
        [str(w.message) for w in caught]
    named = [w for w in result.warnings if path in w]
    assert len(named) == 1, result.warnings
    assert "float32" in named[0], named[0]
    assert np.isfinite(result.rgba).all() and result.rgba[..., :3].max() > 0


def test_float32_max_itself_is_kept():
    """3.4e38 fits: a point there is read (the check is float32's range, not a guess)."""
    stage = _scene()
    _triangle(stage, points=((0, 0, 0.1), (3.4e38, 0, 0.1), (0, 1, 0.1)))
    reader = StageReader(stage)
    reader.sync(None)
    assert TRI in reader.scene.instances
    reader.close()


def test_a_light_whose_normalization_overflows_float32_is_left_out():
    """Numbers the reader makes from valid inputs count too: a normalized 1e30 W/sr
    rect light of 1e-10 x 1e-10 has a radiance of 1e50."""
    stage = _scene()
    rect = UsdLux.RectLight.Define(stage, "/root/tiny")
    rect.CreateIntensityAttr(1e30)
    rect.CreateWidthAttr(1e-10)
    rect.CreateHeightAttr(1e-10)
    rect.CreateNormalizeAttr(True)
    reader = StageReader(stage)
    reader.sync(None)
    assert "/root/tiny" not in reader.scene.lights and "/root/point" in reader.scene.lights
    named = reader.scene.warnings["/root/tiny"]
    assert len(named) == 1 and "its color" in named[0] and "float32" in named[0], named
    reader.close()
