"""The stage reader's light records stay what they were when its reading of light
prims was made cheaper: every record (Light and Dome fields, warnings, which lights
are read again at a new time) on stages with every light type, transforms (an orient
op, scales, a time-sampled parent), sizes whose quotients round, hidden and
time-varying visibility, invalid values, references with an override, a variant, a
sublayer and instance proxies, equal to the last bit to those in
tests/references/light_records.json. That file holds what the reader gave before
(2026-11-28), with the warnings' wording of the float32 check ("not finite in
float32") since, and the fields of an emissive mesh's light (polygons, their colours
and faces) at a UsdLux light's values (none), and a disk's semi-axes since a disk under a
non-uniform scale is an ellipse (width and height; its radiance over pi rx ry, its
radius the larger); `python tests/test_light_read.py --write`
writes it again. Read at
the default time, frame 1 and frame 2, in one reader (the re-read at a new time
included)."""
import dataclasses
import json
import pathlib
import sys

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

from lantern.engine.usd.stage import StageReader

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from light_grids import add_sphere_lights  # noqa: E402

FIXTURE = pathlib.Path(__file__).resolve().parent / "references" / "light_records.json"
FRAMES = (None, 1.0, 2.0)


def _grid():
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Xform.Define(stage, "/root").AddTranslateOp().Set((0.5, -0.25, 2.0))
    g = (np.arange(8) + 0.5) / 8 * 2 - 1
    add_sphere_lights(stage, "/root", [(float(x), float(y), 1.0) for y in g for x in g],
                      {"intensity": 0.3, "specular": 0.0}, False, treat_as_point=True)
    return stage


def _kinds(stage, root="/kinds"):
    """One light of each type, with the inputs and transforms a light may have."""
    UsdGeom.Xform.Define(stage, root).AddRotateXYZOp().Set((10.0, 20.0, 30.0))
    sphere = UsdLux.SphereLight.Define(stage, f"{root}/sphere")
    sphere.CreateIntensityAttr(40.0)
    sphere.CreateExposureAttr(1.5)
    sphere.CreateColorAttr((1.0, 0.5, 0.25))
    sphere.CreateRadiusAttr(0.2)
    sphere.CreateNormalizeAttr(True)
    sphere.AddTranslateOp().Set((1.0, 2.0, 3.0))
    sphere.AddScaleOp().Set((2.0, 2.0, 2.0))
    spot = UsdLux.SphereLight.Define(stage, f"{root}/spot")
    spot.CreateIntensityAttr(100.0)
    spot.CreateRadiusAttr(0.1)
    shaping = UsdLux.ShapingAPI.Apply(spot.GetPrim())
    shaping.CreateShapingConeAngleAttr(35.0)
    shaping.CreateShapingConeSoftnessAttr(0.3)
    spot.AddTranslateOp().Set((0.0, 0.0, 4.0))
    spot.AddOrientOp().Set(Gf.Quatf(0.9238795, 0.3826834, 0.0, 0.0))
    spot.GetPrim().CreateAttribute("lantern:shadowResolution", Sdf.ValueTypeNames.Int).Set(512)
    spot.GetPrim().CreateAttribute("lantern:softFalloff", Sdf.ValueTypeNames.Bool).Set(False)
    rect = UsdLux.RectLight.Define(stage, f"{root}/rect")
    rect.CreateIntensityAttr(7.0)
    rect.CreateWidthAttr(2.0)
    rect.CreateHeightAttr(0.5)
    rect.CreateNormalizeAttr(True)
    rect.CreateDiffuseAttr(0.5)
    rect.CreateSpecularAttr(0.0)
    rect.AddTransformOp().Set(Gf.Matrix4d().SetScale(Gf.Vec3d(1.5, 3.0, 1.0)) *
                              Gf.Matrix4d().SetTranslate(Gf.Vec3d(-1.0, 0.0, 2.0)))
    disk = UsdLux.DiskLight.Define(stage, f"{root}/disk")
    disk.CreateRadiusAttr(0.75)
    disk.CreateIntensityAttr(3.0)
    disk.CreateEnableColorTemperatureAttr(True)     # read by nothing: the record is the same
    disk.AddRotateXOp().Set(90.0)
    # Normalized and unnormalized sizes that round (a quotient or product of three).
    for name, kind, normalize in (("sphere_raw", UsdLux.SphereLight, False),
                                  ("disk_norm", UsdLux.DiskLight, True),
                                  ("rect_norm", UsdLux.RectLight, True)):
        light = kind.Define(stage, f"{root}/{name}")
        light.CreateIntensityAttr(3.7)
        light.CreateColorAttr((0.3, 0.7, 0.11))
        light.CreateNormalizeAttr(normalize)
        light.GetPrim().CreateAttribute("inputs:radius", Sdf.ValueTypeNames.Float).Set(0.37)
        light.GetPrim().CreateAttribute("inputs:width", Sdf.ValueTypeNames.Float).Set(0.3)
        light.GetPrim().CreateAttribute("inputs:height", Sdf.ValueTypeNames.Float).Set(0.7)
        light.AddScaleOp().Set((1.3, 1.1, 0.9))
    sun = UsdLux.DistantLight.Define(stage, f"{root}/sun")
    sun.CreateIntensityAttr(2.5)
    sun.CreateAngleAttr(1.0)
    UsdLux.ShadowAPI.Apply(sun.GetPrim()).CreateShadowEnableAttr(False)
    sun.AddRotateYOp().Set(-40.0)
    dome = UsdLux.DomeLight.Define(stage, f"{root}/dome")
    dome.CreateIntensityAttr(0.25)
    dome.CreateColorAttr((0.5, 0.6, 1.0))
    dome.GetPrim().CreateAttribute("lantern:aoDistance", Sdf.ValueTypeNames.Float).Set(3.0)
    return stage


def _all_kinds():
    return _kinds(Usd.Stage.CreateInMemory())


def _in_time():
    """Time-sampled inputs, a time-sampled parent, visibility that changes, hidden."""
    stage = _kinds(Usd.Stage.CreateInMemory())
    moving = UsdGeom.Xform.Define(stage, "/moving")
    op = moving.AddTranslateOp()
    op.Set((0.0, 0.0, 0.0), 1.0)
    op.Set((2.0, 0.0, 1.0), 2.0)
    lamp = UsdLux.SphereLight.Define(stage, "/moving/lamp")
    lamp.CreateIntensityAttr(5.0)
    pulse = UsdLux.SphereLight.Define(stage, "/pulse")
    pulse.CreateIntensityAttr().Set(1.0, 1.0)
    pulse.GetIntensityAttr().Set(9.0, 2.0)
    pulse.CreateColorAttr().Set((1.0, 0.0, 0.0), 2.0)
    blink = UsdLux.RectLight.Define(stage, "/blink")
    blink.CreateVisibilityAttr().Set(UsdGeom.Tokens.invisible, 1.0)
    blink.GetVisibilityAttr().Set(UsdGeom.Tokens.inherited, 2.0)
    hidden = UsdLux.SphereLight.Define(stage, "/hidden")
    hidden.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    UsdGeom.Imageable(stage.GetPrimAtPath("/kinds/rect")).CreateVisibilityAttr(
        UsdGeom.Tokens.invisible)
    return stage


def _invalid():
    stage = Usd.Stage.CreateInMemory()
    bad = [("nan", "inputs:intensity", float("nan")), ("negative", "inputs:radius", -1.0),
           ("cone", "inputs:shaping:cone:angle", 0.0)]
    for name, attr, value in bad:
        light = UsdLux.SphereLight.Define(stage, f"/bad_{name}")
        if "shaping" in attr:
            UsdLux.ShapingAPI.Apply(light.GetPrim())
        light.GetPrim().GetAttribute(attr).Set(value) if light.GetPrim().HasAttribute(attr) \
            else light.GetPrim().CreateAttribute(attr, Sdf.ValueTypeNames.Float).Set(value)
    quat = UsdLux.SphereLight.Define(stage, "/bad_orient")
    quat.AddOrientOp().Set(Gf.Quatf(float("nan"), 0.0, 0.0, 0.0))
    flat = UsdLux.RectLight.Define(stage, "/flat")
    flat.AddScaleOp().Set((1.0, 0.0, 1.0))
    UsdLux.CylinderLight.Define(stage, "/cylinder")
    UsdLux.SphereLight.Define(stage, "/two_domes_ok")
    UsdLux.DomeLight.Define(stage, "/dome_a")
    UsdLux.DomeLight.Define(stage, "/dome_b").CreateIntensityAttr(2.0)
    return stage


def _composed():
    """Lights through a reference (with an override over it), a variant, a sublayer,
    and inside instances (instance proxies)."""
    library = Usd.Stage.CreateInMemory()
    _kinds(library, "/lib")
    library.SetDefaultPrim(library.GetPrimAtPath("/lib"))
    sub = Sdf.Layer.CreateAnonymous(".usda")
    sub_stage = Usd.Stage.Open(sub)
    UsdLux.SphereLight.Define(sub_stage, "/from_sub").CreateIntensityAttr(11.0)
    UsdLux.SphereLight.Define(sub_stage, "/overridden").CreateIntensityAttr(1.0)

    stage = Usd.Stage.CreateInMemory()
    stage.GetRootLayer().subLayerPaths.append(sub.identifier)
    UsdLux.SphereLight.Define(stage, "/overridden").CreateIntensityAttr(2.0)
    ref = stage.DefinePrim("/ref")
    ref.GetReferences().AddReference(library.GetRootLayer().identifier)
    UsdLux.RectLight(stage.GetPrimAtPath("/ref/rect")).CreateIntensityAttr(70.0)
    UsdGeom.Xformable(ref).AddTranslateOp().Set((0.0, 5.0, 0.0))
    for i in range(3):
        inst = stage.DefinePrim(f"/inst_{i}")
        inst.GetReferences().AddReference(library.GetRootLayer().identifier)
        inst.SetInstanceable(True)
        UsdGeom.Xformable(inst).AddTranslateOp().Set((3.0 * i, 0.0, 0.0))
    var = UsdGeom.Xform.Define(stage, "/var").GetPrim()
    vset = var.GetVariantSets().AddVariantSet("look")
    for name, intensity in (("dim", 0.5), ("bright", 50.0)):
        vset.AddVariant(name)
        vset.SetVariantSelection(name)
        with vset.GetVariantEditContext():
            light = UsdLux.SphereLight.Define(stage, "/var/lamp")
            light.CreateIntensityAttr(intensity)
            light.AddTranslateOp().Set((0.0, 0.0, intensity))
    vset.SetVariantSelection("bright")
    return stage


STAGES = {"grid": _grid, "kinds": _all_kinds, "in_time": _in_time, "invalid": _invalid,
          "composed": _composed}


def _plain(value):
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, float):
        return repr(value)              # every bit (and nan)
    return value


def _record(rec):
    return {f.name: _plain(getattr(rec, f.name)) for f in dataclasses.fields(rec)}


def records(make) -> list:
    """What the reader holds of the stage's lights after each sync in FRAMES."""
    stage = make()
    reader = StageReader(stage)
    out = []
    try:
        for frame in FRAMES:
            changes = reader.sync(frame)
            scene = reader.scene
            out.append({
                "lights": [[name, _record(rec)] for name, rec in scene.lights.items()],
                "dome": _record(scene.dome) if scene.dome is not None else None,
                "warnings": sorted(w for ws in scene.warnings.values() for w in ws),
                "read": sorted(changes.lights), "prims_read": changes.prims_read,
            })
    finally:
        reader.close()
    return out


@pytest.mark.parametrize("name", sorted(STAGES))
def test_light_records_are_unchanged(name):
    expected = json.loads(FIXTURE.read_text())[name]
    got = json.loads(json.dumps(records(STAGES[name])))
    for frame, want, have in zip(FRAMES, expected, got):
        assert have["lights"] == want["lights"], f"{name} at {frame}"
        for key in ("dome", "warnings", "read", "prims_read"):
            assert have[key] == want[key], f"{name} at {frame}: {key}"


if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    FIXTURE.write_text(json.dumps({name: records(make) for name, make in STAGES.items()},
                                  sort_keys=True) + "\n")
    print(f"wrote {FIXTURE}")
