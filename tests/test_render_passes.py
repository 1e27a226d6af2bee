"""Render passes (AOVs): RenderSettings.passes asks for them by Blender's names and
RenderResult.passes holds them, float32, row 0 = top. Checked against closed forms on
a plane seen by a known camera, and for cost: a pass nobody asks for is not computed."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdShade

import shadow_scenes
from lantern.core.passes import BACKGROUND_DEPTH, PASSES, provided
from lantern.engine import RenderSettings, Session

W, H = 64, 36
EYE, TARGET = np.array([0.0, -3.0, 4.0]), np.array([0.0, 0.0, 0.0])
FOCAL, HAP = 20.0, 36.0


def _index(prim, value):
    prim.CreateAttribute("lantern:passIndex", Sdf.ValueTypeNames.Int, custom=True).Set(value)


def _stage():
    """The white plane z = 0 (material pass index 2), two boxes under Xforms with
    object pass indices 3 and 7 (the second emissive, material index 5), a sun."""
    stage = shadow_scenes.new_stage()
    _index(stage.GetPrimAtPath("/root/_materials/white"), 2)
    glow = UsdShade.Material.Define(stage, "/root/_materials/glow")
    sh = UsdShade.Shader.Define(stage, "/root/_materials/glow/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1.0, 2.0, 3.0))
    glow.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    _index(glow.GetPrim(), 5)
    for name, x, index in (("a", -1.2, 3), ("b", 1.2, 7)):
        xf = UsdGeom.Xform.Define(stage, f"/root/{name}")
        _index(xf.GetPrim(), index)
        box = shadow_scenes.add_box(stage, center=(x, 0.0, 0.3), size=0.6, name=f"{name}/box")
        if name == "b":
            UsdShade.MaterialBindingAPI(box.GetPrim()).Bind(glow)
    shadow_scenes.add_light(stage, "sun", strength=2.0, dir=(0.3, 0.2, -1.0))
    shadow_scenes.add_camera(stage, eye=EYE, target=TARGET, focal=FOCAL, hap=HAP, aspect=W / H)
    return stage


def _rays():
    """World directions through each pixel centre (row 0 = top), scaled so that their
    component along the view axis is 1, and that axis."""
    forward = (TARGET - EYE) / np.linalg.norm(TARGET - EYE)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half_w = HAP / 2 / FOCAL
    half_h = half_w * H / W
    x = ((np.arange(W) + 0.5) / W * 2 - 1) * half_w
    y = (1 - (np.arange(H) + 0.5) / H * 2) * half_h
    d = forward + x[None, :, None] * right + y[:, None, None] * up
    return d, forward


@pytest.fixture(scope="module")
def rendered():
    names = frozenset(p.name for p in provided())
    # Closed forms at pixel centres: one sample a pixel (medium supersamples small stills).
    with Session(_stage(), RenderSettings(width=W, height=H, passes=names,
                                          supersample=1)) as session:
        with_passes = session.render()
    with Session(_stage(), RenderSettings(width=W, height=H, supersample=1)) as session:
        without = session.render()
    return with_passes, without


def test_every_provided_pass_has_blenders_shape(rendered):
    result, _ = rendered
    assert sorted(result.passes) == sorted(p.name for p in provided())
    for name, image in result.passes.items():
        assert image.shape == (H, W, PASSES[name].channels) and image.dtype == np.float32, name
        assert np.isfinite(image).all(), name


def _plane(result):
    """Pixels where the plane is seen (neither box)."""
    return result.passes["IndexOB"][..., 0] == 0


def test_depth_is_the_distance_along_the_view_axis(rendered):
    result, _ = rendered
    d, _ = _rays()
    expected = -EYE[2] / d[..., 2]           # eye + t d meets z = 0; d's axial part is 1
    plane = _plane(result)
    depth = result.passes["Depth"][..., 0]
    assert plane.mean() > 0.7
    error = np.abs(depth[plane] - expected[plane]) / expected[plane]
    print(f"Depth vs closed form on the plane: worst relative error {error.max():.1e}")
    assert error.max() < 1e-4
    # Nearer than the plane behind them: the boxes.
    assert (depth[~plane] < expected[~plane]).all()


def test_normal_is_world_space(rendered):
    result, _ = rendered
    normal = result.passes["Normal"]
    plane = _plane(result)
    assert np.abs(normal[plane] - (0.0, 0.0, 1.0)).max() < 1e-3
    lengths = np.linalg.norm(normal[~plane], axis=-1)
    assert np.abs(lengths - 1).max() < 1e-3


def test_object_and_material_indices(rendered):
    result, _ = rendered
    ob, ma = result.passes["IndexOB"][..., 0], result.passes["IndexMA"][..., 0]
    assert set(np.unique(ob)) == {0.0, 3.0, 7.0}
    # Box a is left of the middle, box b right of it.
    cols_a, cols_b = np.nonzero((ob == 3).any(axis=0))[0], np.nonzero((ob == 7).any(axis=0))[0]
    assert cols_a.max() < W // 2 < cols_b.min()
    assert set(np.unique(ma[ob == 0])) == {2.0}
    assert set(np.unique(ma[ob == 3])) == {2.0}
    assert set(np.unique(ma[ob == 7])) == {5.0}


def test_emit_is_the_emission(rendered):
    result, _ = rendered
    emit = result.passes["Emit"]
    ob = result.passes["IndexOB"][..., 0]
    np.testing.assert_allclose(emit[ob == 7], np.broadcast_to((1.0, 2.0, 3.0), emit[ob == 7].shape),
                               rtol=1e-3)
    assert not emit[ob != 7].any()


def test_background_values():
    """Looking at the sky: Depth is Blender's background depth, the others are 0."""
    from lantern.core.transforms import frustum, look_at
    eye = np.array([0.0, -3.0, 0.5])
    view = np.linalg.inv(look_at(eye, eye + [0.0, 1.0, 0.3], np.array([0.0, 0.0, 1.0])))
    proj = frustum(-0.05, 0.05, -0.03, 0.03, 0.05, 100.0)
    with Session(_stage(), RenderSettings(width=W, height=H,
                                          passes=frozenset(["Depth", "Normal", "IndexOB"]))) as s:
        r = s.render(view_matrix=view, projection_matrix=proj)
    sky = r.rgba[..., 3] >= 0    # every pixel; the top rows see no geometry
    top = r.passes["Depth"][0, :, 0]
    assert (top == BACKGROUND_DEPTH).all() and sky.all()
    assert not r.passes["Normal"][0].any() and not r.passes["IndexOB"][0].any()
    assert (r.passes["Depth"][-1, :, 0] < 100).all()     # the bottom rows see the plane


def test_a_pass_nobody_asks_for_costs_nothing(rendered):
    """Without passes, no pass computes them and no target is made for them, and the
    Combined image is the same to the last bit."""
    with_passes, without = rendered
    assert without.passes == {}
    assert "aovs" not in without.stats["passes"] and "aovs" in with_passes.stats["passes"]
    assert np.array_equal(with_passes.rgba, without.rgba)
    # Only the index target when only an index pass is asked for.
    with Session(_stage(), RenderSettings(width=W, height=H, passes=frozenset(["IndexMA"]))) as s:
        r = s.render()
    assert sorted(r.passes) == ["IndexMA"] and "aovs" not in r.stats["passes"]


@pytest.mark.parametrize("name, message", [("Foo", "unknown render pass"),
                                           ("AO", "not computed by the engine yet")])
def test_unknown_or_missing_passes_are_refused(name, message, monkeypatch):
    # Every pass of the table is computed today: mark one as not yet, to check the
    # refusal a future pass gets until it is.
    from dataclasses import replace
    from lantern.core import passes as table
    monkeypatch.setitem(table.PASSES, "AO", replace(table.PASSES["AO"], provided=False))
    with pytest.raises(ValueError, match=message):
        Session(_stage(), RenderSettings(width=8, height=8, passes=frozenset([name])))


def test_combined_is_always_there():
    """'Combined' may be named (Blender lists it); it is the image itself."""
    with Session(_stage(), RenderSettings(width=16, height=9,
                                          passes=frozenset(["Combined", "Depth"]))) as s:
        r = s.render()
    assert sorted(r.passes) == ["Depth"] and r.rgba.shape == (9, 16, 4)
    assert math.isfinite(float(r.passes["Depth"].min()))


def test_an_edited_pass_index_is_read_again():
    stage = _stage()
    with Session(stage, RenderSettings(width=W, height=H, passes=frozenset(["IndexOB"]))) as s:
        before = s.render().passes["IndexOB"]
        _index(stage.GetPrimAtPath("/root/a"), 11)
        after = s.render().passes["IndexOB"]
    assert (after[before == 3] == 11).all() and (after[before != 3] == before[before != 3]).all()


def test_blender_pass_indices_reach_the_passes(empty_scene):
    """Object and material pass indices, exported as lantern:passIndex, come out as
    IndexOB and IndexMA."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    bpy.ops.mesh.primitive_cube_add(location=(0.0, 0.0, 0.0))
    cube = bpy.context.active_object
    cube.pass_index = 4
    material = bpy.data.materials.new("m")
    material.pass_index = 6
    cube.data.materials.append(material)
    camera = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    camera.location, camera.rotation_euler = (0.0, -6.0, 0.0), (math.pi / 2, 0.0, 0.0)
    empty_scene.collection.objects.link(camera)
    empty_scene.camera = camera
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert stage.GetPrimAtPath("/root/Cube").GetAttribute("lantern:passIndex").Get() == 4
    assert stage.GetPrimAtPath("/root/_materials/m").GetAttribute("lantern:passIndex").Get() == 6
    with Session(stage, RenderSettings(width=16, height=16,
                                       passes=frozenset(["IndexOB", "IndexMA"]))) as s:
        r = s.render()
    assert r.passes["IndexOB"][8, 8, 0] == 4 and r.passes["IndexMA"][8, 8, 0] == 6
    assert r.passes["IndexOB"][0, 0, 0] == 0
