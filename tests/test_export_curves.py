"""Blender hair out (docs/stage_contract.md "Curves"): Curves objects exported as
BasisCurves (NurbsCurves for general NURBS) as Blender's own USD exporter writes them,
every Blender curve type drawn where Blender evaluates it, and a hair system rendered
by `lantern render` and by F12 (the same pixels), against Cycles' render of the same
hair (references/curves/hair.exr, made by references/make_prim_references.py --hair).

Figures are printed (pytest -s shows them)."""
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import curve_scenes
from image_metrics import mean_flip

HAIR_REFERENCE = pathlib.Path(__file__).resolve().parent / "references" / "curves" / "hair.exr"
FLIP_HAIR = 0.08


def _export():
    import bpy
    from lantern.exporters import stage_from_depsgraph
    stage, report = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    return stage, report.warnings


def test_hair_is_written_as_blenders_own_exporter_writes_it(tmp_path):
    import bpy
    from pxr import Usd, UsdGeom, UsdShade
    curve_scenes.build_hair()
    stage, warnings = _export()
    assert warnings == []
    bpy.ops.wm.usd_export(filepath=str(tmp_path / "blender.usda"))
    theirs = Usd.Stage.Open(str(tmp_path / "blender.usda"))
    ours = UsdGeom.BasisCurves(stage.GetPrimAtPath("/root/Hair/Hair"))
    blender = next(UsdGeom.BasisCurves(p) for p in theirs.Traverse() if p.IsA(UsdGeom.BasisCurves))
    for attr in ("Type", "Basis", "Wrap"):
        assert getattr(ours, f"Get{attr}Attr")().Get() == getattr(blender, f"Get{attr}Attr")().Get()
    assert list(ours.GetCurveVertexCountsAttr().Get()) == \
        list(blender.GetCurveVertexCountsAttr().Get())
    assert np.allclose(ours.GetPointsAttr().Get(), blender.GetPointsAttr().Get(), atol=1e-6)
    assert np.allclose(ours.GetWidthsAttr().Get(), blender.GetWidthsAttr().Get(), atol=1e-7)
    assert ours.GetWidthsInterpolation() == blender.GetWidthsInterpolation() == "vertex"
    bound = UsdShade.MaterialBindingAPI(ours.GetPrim()).GetDirectBinding().GetMaterialPath()
    assert stage.GetPrimAtPath(bound).GetAttribute("lantern:blenderName").Get() == "HairMaterial"


@pytest.mark.parametrize("name", sorted(curve_scenes.CURVES))
def test_each_blender_curve_type_is_drawn_where_blender_evaluates_it(name):
    """Blender's Poly, Bezier (its handles), NURBS (uniform, cyclic, padded) curves,
    exported and sampled by the engine, lie on Blender's own evaluation of them."""
    import bpy
    from pxr import Usd
    from lantern.engine.usd.curves import polylines
    curve_scenes.build_blender(evaluate=False)
    points, radii, cyclic = curve_scenes.evaluated(bpy.data.objects[name])
    stage, warnings = _export()
    assert warnings == []
    prim = stage.GetPrimAtPath(f"/root/{name}/{name}")
    lines = polylines(prim, Usd.TimeCode.Default())
    samples = np.concatenate([lines.points, lines.points[:1]]) if lines.closed[0] else lines.points
    a, b = samples[:-1], samples[1:]
    ab = b - a
    t = np.clip(np.einsum("pij,ij->pi", points[:, None] - a[None], ab) /
                np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30), 0, 1)
    distance = np.linalg.norm(points[:, None] - (a[None] + t[..., None] * ab[None]), axis=2)
    extent = np.linalg.norm(samples.max(axis=0) - samples.min(axis=0))
    print(f"{name}: {prim.GetTypeName()} {prim.GetAttribute('basis').Get()} "
          f"{prim.GetAttribute('wrap').Get()}, {distance.min(axis=1).max() / extent:.1e} of its "
          f"size from Blender's curve")
    assert distance.min(axis=1).max() <= 1.5e-3 * extent
    assert bool(lines.closed[0]) == cyclic


def test_a_general_nurbs_curve_is_written_as_nurbs_curves():
    import bpy
    from pxr import Usd, UsdGeom
    from lantern.engine.usd.curves import polylines
    bpy.ops.wm.read_factory_settings(use_empty=True)
    data = bpy.data.hair_curves.new("Arc")
    data.add_curves([5])
    data.set_types(type="NURBS")
    data.attributes.new("nurbs_order", "INT8", "CURVE").data[0].value = 3
    data.attributes.new("knots_mode", "INT8", "CURVE").data[0].value = 1     # Endpoint
    for i, p in enumerate([(0, 0, 0), (1, 2, 0), (2, -1, 0), (3, 2, 1), (4, 0, 0)]):
        data.points[i].position = p
    ob = bpy.data.objects.new("Arc", data)
    bpy.context.scene.collection.objects.link(ob)
    data.attributes.new("resolution", "INT", "CURVE").data[0].value = 64
    points, _, _ = curve_scenes.evaluated(ob)
    stage, warnings = _export()
    prim = stage.GetPrimAtPath("/root/Arc/Arc")
    assert prim.IsA(UsdGeom.NurbsCurves) and warnings == []
    assert list(prim.GetAttribute("knots").Get()) == [0, 0, 0, 1, 2, 3, 3, 3]
    lines = polylines(prim, Usd.TimeCode.Default())
    assert np.allclose(lines.points[[0, -1]], points[[0, -1]], atol=1e-6)  # clamped: ends on them
    nearest = np.linalg.norm(points[:, None] - lines.points[None], axis=2).min(axis=1)
    assert nearest.max() < 0.02


def _cli(*args):
    proc = subprocess.run([sys.executable, "-m", "lantern", *args], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return proc


def test_hair_renders_with_lantern_render_and_f12(tmp_path):
    """The hair scene saved as a .blend: `lantern render` draws the hair (the image
    differs from the scene without it on the hair's pixels), F12 gives the same
    pixels, and both are within FLIP_HAIR of Cycles' render of Blender's hair (the high
    preset: strands about a pixel wide want its supersampling; medium gives 0.099)."""
    import bpy
    import lantern
    from lantern.engine import read_exr
    w, h = curve_scenes.HAIR_SIZE
    images = {}
    for hidden in (False, True):
        curve_scenes.build_hair(hidden=hidden)
        blend = tmp_path / f"hair{'_hidden' if hidden else ''}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(blend))
        out = tmp_path / f"cli{'_hidden' if hidden else ''}.exr"
        proc = _cli("render", str(blend), "-o", str(out), "--size", f"{w}x{h}",
                    "--preset", "high")
        assert "warning" not in proc.stderr, proc.stderr
        images[hidden] = read_exr(str(out))
    hair = np.abs(images[False] - images[True])[..., :3].max(axis=-1) > 0.02
    print(f"hair covers {hair.mean():.1%} of the image")
    assert hair.mean() > 0.05
    lantern.register()
    try:
        scene = curve_scenes.build_hair()
        scene.render.engine = 'LANTERN'
        scene.lantern.preset = "high"     # strands a pixel wide: supersampled, as the CLI
        scene.render.image_settings.file_format = 'OPEN_EXR'
        scene.render.image_settings.color_depth = '32'
        scene.render.filepath = str(tmp_path / "f12.exr")
        bpy.ops.render.render(write_still=True)
    finally:
        lantern.unregister()
    f12 = read_exr(str(tmp_path / "f12.exr"))
    difference = np.abs(f12 - images[False]).max()
    cycles = read_exr(str(HAIR_REFERENCE))
    flip = mean_flip(images[False], cycles)
    print(f"max |F12 - CLI| = {difference:.2e}; FLIP against Cycles {flip:.4f}")
    assert difference <= 1e-3
    assert flip <= FLIP_HAIR
