"""engine.Session, the renderer that outlives a frame: work follows what
changed. Views, edits through the USD API and new times read and upload only what
they touch, and every image equals a fresh render_stage of the same stage."""
import os

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt

import session_scenes as scenes
import shadow_scenes
from _export_helpers import skinned_stage
from lantern.engine import RenderSettings, Session, render_sequence, render_stage
from skel_scenes import crowd_stage, skel_stage

W, H = 96, 64
KB16 = 16 * 1024


def fresh(stage, **kw):
    return render_stage(stage, RenderSettings(width=W, height=H, **kw)).rgba


# --- views ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def thousand():
    """1,000 separate cubes on a floor, a static point and a static spot light, both
    casting shadows, and a Session that rendered it once."""
    stage = scenes.cubes_stage(1000, lights=("point", "spot"))
    session = Session(stage, RenderSettings(width=W, height=H))
    first = session.render()
    yield stage, session, first
    session.close()


def test_first_render_reads_and_uploads_everything(thousand):
    _, _, first = thousand
    assert first.stats["meshes_uploaded"] == 1001          # the cubes and the floor
    assert first.stats["prims_read"] >= 1000
    assert first.stats["shadow_maps_rendered"] == 2
    assert first.stats["bytes_uploaded"] >= 1000 * (8 * 48 + 36 * 4)  # each cube: 8 vertices, 12 triangles


def test_view_changes_read_and_upload_nothing_but_the_draw_order(thousand):
    stage, session, _ = thousand
    for view, proj in scenes.orbit_views(stage, 6, W / H):
        result = session.render(view, proj)
        s = result.stats
        assert s["meshes_uploaded"] == 0 and s["prims_read"] == 0, s
        assert s["shadow_maps_rendered"] == 0 and s["shadow_maps"] == 2, s
        assert s["bytes_uploaded"] <= KB16, s["bytes_by_kind"]
        assert s["draw_calls"] > 100                      # it did draw the cubes
        same = fresh(stage, view_matrix=view, projection_matrix=proj)
        assert np.abs(result.rgba - same).max() <= 1e-5


# --- edits through the USD API ---------------------------------------------------------

def _screen_rect(box, view, proj, size, margin=1):
    """Pixel rectangle (row0, row1, col0, col1) of a world box seen by view/proj."""
    lo, hi = box
    w, h = size
    corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    clip = corners @ (proj @ view).T
    ndc = clip[:, :2] / clip[:, 3:4]
    cols = (ndc[:, 0] * 0.5 + 0.5) * w
    rows = (0.5 - ndc[:, 1] * 0.5) * h
    return (int(np.floor(rows.min())) - margin, int(np.ceil(rows.max())) + margin,
            int(np.floor(cols.min())) - margin, int(np.ceil(cols.max())) + margin)


def test_moving_one_object_changes_only_where_it_is():
    size = (160, 96)
    stage = scenes.cubes_stage(1000)            # the default light rig: no shadows
    view, proj = scenes.orbit_views(stage, 6, size[0] / size[1], radius=14.0, height=7.0)[1]
    # The cube nearest the camera among those seen in the middle of the image.
    centres = np.array(scenes.grid_positions(1000))
    clip = np.c_[centres, np.ones(len(centres))] @ (proj @ view).T
    ndc = clip[:, :2] / clip[:, 3:4]
    middle = np.all(np.abs(ndc) < 0.5, axis=1) & (clip[:, 3] > 0)
    nearest = int(np.flatnonzero(middle)[np.argmin(clip[middle, 3])])
    # No ambient occlusion or FXAA: a moved cube changes its neighbours' occlusion, and
    # FXAA's edge search reaches along edges past it, rightly; this checks where the
    # engine redraws, not how far screen-space effects reach.
    settings = RenderSettings(width=size[0], height=size[1], ambient_occlusion=False, fxaa=False)
    lift = np.array([0.3, 0.2, 1.2])
    with Session(stage, settings) as session:
        before = session.render(view, proj).rgba
        op = UsdGeom.Xformable(stage.GetPrimAtPath(f"/root/c{nearest:04d}")).GetOrderedXformOps()[0]
        old = np.array(op.Get())
        op.Set(Gf.Vec3d(*(old + lift)))
        after = session.render(view, proj)
    s = after.stats
    assert s["prims_read"] == 1, s
    assert s["bytes_uploaded"] <= KB16 and s["meshes_uploaded"] == 0, s["bytes_by_kind"]
    changed = np.abs(after.rgba - before).max(axis=-1) > 0
    assert changed.sum() > 30, "the move is not in the image"
    allowed = np.zeros_like(changed)
    for centre in (old, old + lift):
        r0, r1, c0, c1 = _screen_rect((centre - 0.4, centre + 0.4), view, proj, size)
        allowed[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = True
    assert not np.any(changed & ~allowed), "pixels changed away from the object"
    same = render_stage(stage, RenderSettings(width=size[0], height=size[1], view_matrix=view,
                                              projection_matrix=proj,
                                              ambient_occlusion=False, fxaa=False)).rgba
    assert np.abs(after.rgba - same).max() <= 1e-5


def small_stage():
    """A box on a floor, a shadowed spot light, a camera: quick to render fresh."""
    stage = shadow_scenes.new_stage(half=6.0)
    shadow_scenes.add_box(stage, center=(0, 0, 0.5))
    shadow_scenes.add_light(stage, "spot", pos=(-2.0, -1.0, 4.0), aim=(0, 0, 0), power=2000.0,
                            cone=40.0)
    shadow_scenes.add_camera(stage, eye=(5, -6, 4), target=(0, 0, 0.5))
    scenes.material(stage, "red", (0.9, 0.1, 0.1))
    return stage


def add_cube(stage, path, at, material=None):
    xf = UsdGeom.Xform.Define(stage, path)
    xf.AddTranslateOp().Set(Gf.Vec3d(*at))
    mesh = UsdGeom.Mesh.Define(stage, path + "/mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([tuple(p) for p in scenes.CUBE_POINTS * 0.6])
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr(scenes.CUBE_INDICES)
    if material:
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(
            UsdShade.Material(stage.GetPrimAtPath(material)))
    return mesh


def _edit_matches_fresh(edit):
    stage = small_stage()
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        before = session.render().rgba
        edit(stage)
        after = session.render()
    assert np.abs(after.rgba - before).max() > 0.01, "the edit did not show"
    assert np.abs(after.rgba - fresh(stage)).max() <= 1e-5
    return after.stats


def test_added_prim_is_picked_up():
    stats = _edit_matches_fresh(lambda st: add_cube(st, "/root/extra", (1.5, 1.0, 0.3), "/root/_materials/red"))
    assert stats["meshes_uploaded"] == 1 and stats["shadow_maps_rendered"] == 1


def test_removed_prim_is_picked_up():
    stats = _edit_matches_fresh(lambda st: st.RemovePrim("/root/box"))
    assert stats["meshes_uploaded"] == 0 and stats["prims_read"] == 0


def test_material_change_is_picked_up():
    def edit(stage):
        shader = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/white/surface"))
        shader.GetInput("diffuseColor").Set(Gf.Vec3f(0.2, 0.5, 0.9))
    stats = _edit_matches_fresh(edit)
    assert stats["meshes_uploaded"] == 0 and stats["shadow_maps_rendered"] == 0


def test_material_binding_change_is_picked_up():
    def edit(stage):
        UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/root/box")).Bind(
            UsdShade.Material(stage.GetPrimAtPath("/root/_materials/red")))
    _edit_matches_fresh(edit)


def test_light_change_is_picked_up():
    def edit(stage):
        light = UsdLux.SphereLight(stage.GetPrimAtPath("/root/spot"))
        light.GetIntensityAttr().Set(light.GetIntensityAttr().Get() * 0.5)
    stats = _edit_matches_fresh(edit)
    assert stats["shadow_maps_rendered"] == 1 and stats["prims_read"] == 1


def test_light_move_is_picked_up():
    def edit(stage):
        op = UsdGeom.Xformable(stage.GetPrimAtPath("/root/spot")).GetOrderedXformOps()[0]
        op.Set(Gf.Matrix4d().SetLookAt(Gf.Vec3d(2, -1, 4), Gf.Vec3d(0, 0, 0),
                                       Gf.Vec3d(0, 0, 1)).GetInverse())
    _edit_matches_fresh(edit)


def test_points_edit_re_uploads_that_mesh():
    def edit(stage):
        attr = UsdGeom.Mesh(stage.GetPrimAtPath("/root/box")).GetPointsAttr()
        attr.Set(Vt.Vec3fArray.FromNumpy(np.array(attr.Get(), np.float32) * (1.0, 1.0, 1.6)))
    stats = _edit_matches_fresh(edit)
    assert stats["meshes_uploaded"] == 1 and stats["prims_read"] == 1


def test_new_light_and_visibility_are_picked_up():
    def edit(stage):
        shadow_scenes.add_light(stage, "point", pos=(1.5, 1.5, 2.0), power=500.0, name="lamp")
        UsdGeom.Imageable(stage.GetPrimAtPath("/root/box")).MakeInvisible()
    _edit_matches_fresh(edit)


def test_shadow_map_redrawn_only_when_a_caster_in_its_reach_moves():
    stage = small_stage()
    add_cube(stage, "/root/far", (900.0, 0.0, 0.3))   # beyond the spot's light volume
    near = UsdGeom.Xformable(stage.GetPrimAtPath("/root/box"))
    far = UsdGeom.Xformable(stage.GetPrimAtPath("/root/far")).GetOrderedXformOps()[0]
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        session.render()
        far.Set(Gf.Vec3d(950.0, 10.0, 0.3))
        assert session.render().stats["shadow_maps_rendered"] == 0
        near.AddTranslateOp(opSuffix="nudge").Set(Gf.Vec3d(0.3, 0.0, 0.0))
        moved = session.render()
        assert moved.stats["shadow_maps_rendered"] == 1
        assert np.abs(moved.rgba - fresh(stage)).max() <= 1e-5


def test_a_cube_map_redraws_only_the_faces_a_moving_caster_is_in():
    stage = shadow_scenes.new_stage(half=8.0)
    shadow_scenes.add_box(stage, center=(2.5, 0.0, 0.5))          # on the light's +X side
    shadow_scenes.add_light(stage, "point", pos=(0.0, 0.0, 1.5), power=800.0)
    shadow_scenes.add_camera(stage, eye=(3, -7, 6), target=(1, 0, 0))
    box = UsdGeom.Xformable(stage.GetPrimAtPath("/root/box"))
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        assert session.render().stats["shadow_passes"] == 6
        box.AddTranslateOp().Set(Gf.Vec3d(0.4, 0.3, 0.0))
        moved = session.render()
    assert moved.stats["shadow_maps_rendered"] == 1
    assert 1 <= moved.stats["shadow_passes"] <= 3, moved.stats["shadow_passes"]
    assert np.abs(moved.rgba - fresh(stage)).max() <= 1e-5


# --- time --------------------------------------------------------------------------------

def test_frame_change_on_a_rig_uploads_joints_and_weights_and_skins_once():
    stage = crowd_stage()
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        first = session.render(frame=1)
        assert first.stats["meshes_skinned"] == 2
        second = session.render(frame=2)
        view = session.render(frame=2, view_matrix=np.linalg.inv(np.array(
            Gf.Matrix4d().SetLookAt(Gf.Vec3d(3, -8, 6), Gf.Vec3d(2, 0, 0), Gf.Vec3d(0, 0, 1))
            .GetInverse()).T), projection_matrix=scenes.orbit_views(stage, 1, W / H)[0][1])
    s = second.stats
    # Joint matrices and blend-shape weights; "commands" is the view's draw order (posed
    # objects may swap places front to back), 4 bytes per object: no mesh data.
    assert set(s["bytes_by_kind"]) <= {"joints", "shapes", "commands"}, s["bytes_by_kind"]
    assert s["bytes_by_kind"].get("commands", 0) <= 4 * 4
    assert s["bytes_by_kind"]["joints"] > 0 and s["bytes_by_kind"]["shapes"] > 0
    assert s["meshes_uploaded"] == 0
    # Two skinned meshes, skinned once each, though 7 shadow tiles (a cube and a spot)
    # and the G-buffer all draw them.
    assert s["meshes_skinned"] == 2 and s["shadow_maps_rendered"] == 2, s
    assert s["shadow_passes"] == 7
    assert np.abs(second.rgba - fresh(stage, frame=2)).max() <= 1e-5
    # A view change at the same time deforms nothing.
    assert view.stats["meshes_skinned"] == 0 and view.stats["prims_read"] == 0


def test_frame_change_reads_only_what_varies():
    stage = crowd_stage()
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        session.render(frame=1)
        stats = session.render(frame=3).stats
    # The skeleton's pose and the blend-shape weights of the mesh that has them;
    # nothing static (floor, lights, camera, the first mesh's data).
    assert stats["prims_read"] == 2, stats


def rss_mib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="reads /proc")
def test_a_long_sequence_keeps_memory_flat():
    """300 frames of a mesh whose points are sampled at every frame: each frame
    rewrites that mesh in place; nothing accumulates per frame (the engine used to
    keep every frame's mesh, about 5.8 MiB a frame)."""
    stage = scenes.time_sampled_mesh_stage(frames=300, grid=64)
    rss = {}
    for frame, result in render_sequence(stage, 1, 300, RenderSettings(width=32, height=24)):
        rss[frame] = rss_mib()
        assert frame == 1 or result.stats["meshes_uploaded"] == 1   # the wave, not the floor
    growth = max(rss[f] for f in rss if f > 10) - rss[10.0]
    print(f"RSS at frame 10: {rss[10.0]:.1f} MiB, largest growth after: {growth:.1f} MiB")
    assert growth <= 50.0


# --- the default view ------------------------------------------------------------------

def test_skinned_stage_and_its_baked_twin_frame_alike():
    """Without a camera the default view frames what is drawn at that time: the
    posed mesh, whether UsdSkel deforms it on the GPU or it was baked."""
    stage = skel_stage(5, influences=3, grid=12, rot_deg=60)
    # Authored normals, which UsdSkel bakes too (smooth normals of the baked points
    # would differ from skinned rest normals, a shading difference, not a framing one).
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/root/mesh"))
    mesh.CreateNormalsAttr([Gf.Vec3f(0, 0.3, 1)] * len(mesh.GetPointsAttr().Get()))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    baked = skinned_stage(stage)
    for t in (1, 3):
        a = fresh(stage, frame=t)
        b = fresh(baked, frame=t)
        assert np.abs(a - b).max() <= 1e-3, t
    assert np.abs(fresh(stage, frame=1) - fresh(stage, frame=3)).max() > 0.05


@pytest.mark.parametrize("normal", [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, -1, 0)])
def test_flat_plane_without_camera_fills_the_view(normal):
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    n = np.array(normal, float)
    u = np.cross(n, [0, 0, 1.0] if abs(n[2]) < 0.9 else [1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    mesh = UsdGeom.Mesh.Define(stage, "/plane")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([tuple(2 * (a * u + b * v)) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])   # single-sided by USD's default
    cover = render_stage(stage, RenderSettings(width=W, height=H, transparent=True)).rgba[..., 3]
    # The bounding sphere fills the narrower field of view, as usdview frames: a
    # square seen from 35 degrees above covers about 17 % of a 3:2 image, whichever
    # way it faces (edge-on it would cover none).
    assert cover.mean() > 0.15, cover.mean()


def test_openusd_blendshapes_plane_renders(corpus):
    """A single-sided plane facing +Y: usdview shows it, and so does Lantern now."""
    path = corpus / "usdskel/usd/usdSkel/testenv/testUsdSkelBakeSkinning/blendshapes.usda"
    stage = Usd.Stage.Open(str(path))
    cover = render_stage(stage, RenderSettings(width=W, height=H, transparent=True)).rgba[..., 3]
    assert cover.mean() > 0.1, cover.mean()


# --- back faces ----------------------------------------------------------------------------

def facing_away_stage(double_sided=False, marker=None):
    stage = shadow_scenes.new_stage(half=0.5)        # a unit plane at z = 0, facing +Z
    plane = stage.GetPrimAtPath("/root/plane")
    UsdGeom.Mesh(plane).GetDoubleSidedAttr().Set(double_sided)
    if marker is not None:
        plane.CreateAttribute("lantern:backfaceCulling", Sdf.ValueTypeNames.Bool).Set(marker)
    shadow_scenes.add_camera(stage, eye=(0.2, 0.3, -3.0), target=(0, 0, 0))  # from below
    return stage


@pytest.mark.parametrize("double_sided, marker, setting, visible", [
    (False, None, False, True),     # as usdview: both sides unless culling was asked for
    (False, True, False, False),    # the exporter's marker (Blender's Backface Culling)
    (False, False, True, False),    # RenderSettings.cull_backfaces: every single-sided mesh
    (True, True, True, True),       # a double-sided mesh is never culled
])
def test_back_faces_are_culled_only_where_asked(double_sided, marker, setting, visible):
    stage = facing_away_stage(double_sided, marker)
    rgba = render_stage(stage, RenderSettings(width=32, height=32, transparent=True,
                                              cull_backfaces=setting)).rgba
    assert (rgba[16, 16, 3] == 1.0) == visible


# --- GL paths, passes, cameras, lifetime ------------------------------------------------------

def mixed_stage():
    """Several materials, a mirrored object, a single-sided culled mesh, a skinned
    mesh, a shadowed light: every kind of batch."""
    stage = skel_stage(4, influences=2, grid=10, rot_deg=60)
    for name, c in (("red", (0.9, 0.1, 0.1)), ("green", (0.1, 0.8, 0.2))):
        scenes.material(stage, name, c)
    add_cube(stage, "/root/a", (-1.5, -1.0, 0.0), "/root/_materials/red")
    add_cube(stage, "/root/b", (2.0, -1.5, 0.0), "/root/_materials/green")
    UsdGeom.Xformable(stage.GetPrimAtPath("/root/b")).AddScaleOp().Set(Gf.Vec3f(-1, 1, 1))
    culled = add_cube(stage, "/root/c", (4.5, -1.0, 0.2))
    culled.CreateDoubleSidedAttr(False)
    culled.GetPrim().CreateAttribute("lantern:backfaceCulling", Sdf.ValueTypeNames.Bool).Set(True)
    shadow_scenes.add_light(stage, "spot", pos=(1.0, -3.0, 5.0), aim=(2, 0, 0), power=3000.0,
                            cone=50.0)
    shadow_scenes.add_camera(stage, eye=(2, -9, 5), target=(2, 0, 0))
    return stage


def test_gl33_path_draws_the_same_pixels_as_multi_draw(monkeypatch):
    # GL 4.4: multi-draw without glClipControl, so both paths share the depth
    # convention's [-1, 1] fallback (engine/view.py) and differ only in how they draw.
    stage = mixed_stage()
    monkeypatch.setenv("LANTERN_MAX_GL", "44")
    multi = render_stage(stage, RenderSettings(width=W, height=H, frame=2))
    monkeypatch.setenv("LANTERN_MAX_GL", "33")
    single = render_stage(stage, RenderSettings(width=W, height=H, frame=2))
    assert multi.stats["gl_path"] != single.stats["gl_path"]
    assert "3.3" in single.stats["gl_path"]
    assert multi.stats["draw_calls"] == single.stats["draw_calls"] == 4
    assert multi.stats["shadow_draws"] == single.stats["shadow_draws"] > 0
    assert np.abs(multi.rgba - single.rgba).max() == 0.0


def test_passes_a_scene_does_not_need_do_not_run():
    stage = small_stage()
    UsdLux.ShadowAPI(stage.GetPrimAtPath("/root/spot")).GetShadowEnableAttr().Set(False)
    with Session(stage, RenderSettings(width=W, height=H)) as session:
        result = session.render()
        renderer = session._renderer
        assert "shadows" not in result.stats["passes"] and "skinning" not in result.stats["passes"]
        assert renderer.pool.held() == 0 and not renderer.shadows.maps
        assert renderer.geometry.dynamic is None and not renderer.skinning.inputs
    rig = mixed_stage()
    with Session(rig, RenderSettings(width=W, height=H)) as session:
        passes = session.render().stats["passes"]
        assert passes[:3] == ["skinning", "view", "shadows"]
        assert session._renderer.pool.held() == 1          # the spot's kept shadow map


def test_camera_setting_picks_a_camera():
    stage = small_stage()
    cam2 = UsdGeom.Camera.Define(stage, "/root/cam2")
    cam2.CreateFocalLengthAttr(20.0)
    cam2.AddTransformOp().Set(Gf.Matrix4d().SetLookAt(
        Gf.Vec3d(-5, 6, 3), Gf.Vec3d(0, 0, 0.5), Gf.Vec3d(0, 0, 1)).GetInverse())
    first = fresh(stage)                          # the first camera found
    other = fresh(stage, camera="/root/cam2")
    assert np.abs(first - other).max() > 0.05
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/root/cam2"])
    assert np.abs(fresh(stage) - other).max() == 0.0   # /Render/Settings' camera
    with pytest.raises(ValueError, match="/root/box"):
        fresh(stage, camera="/root/box")


def test_close_releases_the_gpu_state():
    stage = small_stage()
    session = Session(stage, RenderSettings(width=W, height=H))
    session.render()
    vbo = session._renderer.geometry.static.vbo
    table = session._renderer.lights.texture
    session.close()
    assert type(vbo.mglo).__name__ == "InvalidObject"
    assert type(table.mglo).__name__ == "InvalidObject"
    with pytest.raises(RuntimeError, match="closed"):
        session.render()


def test_blender_backface_culling_reaches_the_engine(empty_scene):
    """Blender's per-material Backface Culling is exported as doubleSided = false plus
    lantern:backfaceCulling, and the engine culls exactly those meshes."""
    import bpy
    from lantern.exporters import stage_from_depsgraph
    for name, cull, x in (("Culled", True, -1.2), ("Shown", False, 1.2)):
        bpy.ops.mesh.primitive_plane_add(size=2.0, location=(x, 0, 0))
        ob = bpy.context.active_object
        ob.name = name
        mat = bpy.data.materials.new(name)
        mat.use_backface_culling = cull
        ob.data.materials.append(mat)
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    culled = stage.GetPrimAtPath("/root/Culled").GetChildren()[0]
    shown = stage.GetPrimAtPath("/root/Shown").GetChildren()[0]
    assert culled.GetAttribute("doubleSided").Get() is False
    assert culled.GetAttribute("lantern:backfaceCulling").Get() is True
    assert shown.GetAttribute("doubleSided").Get() is True
    assert not shown.GetAttribute("lantern:backfaceCulling").HasValue()
    # Seen from below: the culled plane alone shows nothing, until its marker goes.
    cam = UsdGeom.Camera.Define(stage, "/root/below")
    cam.AddTransformOp().Set(Gf.Matrix4d().SetLookAt(
        Gf.Vec3d(0, 0, -8), Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 1, 0)).GetInverse())
    settings = RenderSettings(width=64, height=32, transparent=True, camera="/root/below")
    both = render_stage(stage, settings).rgba[..., 3]
    stage.RemovePrim("/root/Shown")
    alone = render_stage(stage, settings).rgba[..., 3]
    culled.GetAttribute("lantern:backfaceCulling").Set(False)
    unmarked = render_stage(stage, settings).rgba[..., 3]
    assert both.sum() > 50 and alone.sum() == 0 and unmarked.sum() > 50
