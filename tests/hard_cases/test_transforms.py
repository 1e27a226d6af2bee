"""Transforms: objects are written as translate · orient · scale wherever that is exact
(the matrix op only for shear), far from the origin in double precision, finite
under zero-scale parents; NaN or Inf is an ExportError naming the object, and nothing
is written."""
import numpy as np
import pytest

BOUND = 1e-5


def _ops(prim):
    from pxr import UsdGeom
    return [op.GetOpName() for op in UsdGeom.Xformable(prim).GetOrderedXformOps()]


def _world(stage, name, time=0.0):
    from pxr import UsdGeom
    from _export_helpers import object_paths
    prim = stage.GetPrimAtPath(object_paths(stage)[name])
    return np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)).T, prim


def _relative(a, b):
    return float(np.abs(a - b).max()) / max(1.0, float(np.abs(b).max()))


def test_rotated_scaled_mirrored_and_distant_objects_are_trs(empty_scene, hard_case):
    from _export_helpers import cube_object, export_current
    obs = {"Turned": ((1, 2, 3), (0.3, -1.2, 2.9), (1, 2, 0.5)),
           "Mirrored": ((0, 0, 0), (0.1, 0.2, 0.3), (-1, 1, 1)),
           "Far": ((1e6 + 0.125, -3e6, 2e5), (0.5, 0.5, 0.5), (1, 1, 1)),
           "Tiny": ((1e-4, 0, 0), (0, 0, 1), (1e-4, 1e-4, 1e-4))}
    for name, (loc, rot, scale) in obs.items():
        ob = cube_object(name)
        ob.location, ob.rotation_euler, ob.scale = loc, rot, scale
    stage, _ = export_current()
    import bpy
    worst = 0.0
    for name in obs:
        got, prim = _world(stage, name)
        assert _ops(prim) == ["xformOp:translate", "xformOp:orient", "xformOp:scale"], name
        want = np.array(bpy.context.scene.objects[name].matrix_world, dtype=np.float64)
        worst = max(worst, _relative(got, want))
    hard_case("TRS objects (rotated, mirrored, 1e6 m away, 1e-4 scale) vs matrix_world, relative",
              worst, 1e-6)


def test_shear_keeps_the_matrix(empty_scene, hard_case):
    import bpy
    from _export_helpers import cube_object, export_current
    parent = cube_object("Squashed")
    parent.scale = (1, 3, 0.5)
    child = cube_object("Turned")
    child.parent = parent
    # Parented keeping its transform: the parent inverse undoes the non-uniform scale,
    # so the local matrix (inverse scale · rotation) shears.
    bpy.context.view_layer.update()
    child.matrix_parent_inverse = parent.matrix_world.inverted()
    child.rotation_euler = (0.4, 0.7, 0.2)
    stage, _ = export_current()
    got, prim = _world(stage, "Turned")
    assert _ops(prim) == ["xformOp:transform"]
    want = np.array(bpy.context.scene.objects["Turned"].matrix_world, dtype=np.float64)
    hard_case("sheared child (non-uniform parent) vs matrix_world, relative",
              _relative(got, want), 1e-6)
    assert _ops(stage.GetPrimAtPath("/root/Squashed")) == \
        ["xformOp:translate", "xformOp:orient", "xformOp:scale"]


def test_zero_scale_parent_exports_finite_children(empty_scene, hard_case):
    import bpy
    from _export_helpers import cube_object, export_current
    parent = cube_object("Gone")
    parent.scale = (0, 0, 0)
    child = cube_object("Child")
    child.parent = parent
    child.location = (1, 2, 3)
    flat = cube_object("Flat")
    flat.scale = (1, 0, 1)
    stage, _ = export_current()
    for name in ("Gone", "Child", "Flat"):
        got, _ = _world(stage, name)
        assert np.isfinite(got).all(), name
        want = np.array(bpy.context.scene.objects[name].matrix_world, dtype=np.float64)
        hard_case(f"zero-scale family: {name} vs matrix_world, relative", _relative(got, want), 1e-6)


@pytest.mark.parametrize("what", ["location", "rotation", "scale", "vertex", "normal-free uv",
                                  "animated location"])
def test_non_finite_input_is_an_error_and_nothing_is_written(empty_scene, tmp_path, what):
    import bpy
    from _export_helpers import cube_object
    from lantern.exporters import ExportError, export_depsgraph_to_file
    ob = cube_object("Broken")
    cube_object("Fine")
    nan = float("nan")
    if what == "location":
        ob.location = (nan, 0, 0)
    elif what == "rotation":
        ob.rotation_euler = (0, nan, 0)  # (Blender clamps Inf to the float maximum)
    elif what == "scale":
        ob.scale = (1, nan, 1)
    elif what == "vertex":
        ob.data.vertices[3].co = (nan, 0, 0)
    elif what == "normal-free uv":
        layer = ob.data.uv_layers.new(name="UVMap")
        layer.data[2].uv = (nan, 0.5)
    else:
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 3
        for f, x in ((1, 0.0), (2, nan), (3, 1.0)):
            ob.location = (x, 0, 0)
            ob.keyframe_insert("location", frame=f)
        scene.frame_set(1)
    bpy.context.view_layer.update()
    out = tmp_path / "out.usda"
    with pytest.raises(ExportError) as error:
        export_depsgraph_to_file(bpy.context.evaluated_depsgraph_get(), str(out))
    message = str(error.value)
    assert "'Broken'" in message and "non-finite" in message and "\n" not in message
    assert not out.exists() and list(tmp_path.iterdir()) == [], "something was written"
