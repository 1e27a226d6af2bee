"""Stage fragments (engine/usd/fragments.py): edits made on a mirror stage, encoded
from what USD reported changed, applied to another stage, leave both layers equal,
and the receiver's stage reports the same minimal change the mirror did."""
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from lantern.engine.usd.changes import ChangeTracker
from lantern.engine.usd.fragments import ARRAY_MIN, apply, encode, size


def _pair():
    mirror, receiver = Usd.Stage.CreateInMemory(), Usd.Stage.CreateInMemory()
    return mirror, ChangeTracker(mirror), receiver, ChangeTracker(receiver)


def _send(mirror, tracker, receiver):
    fragment = encode(mirror.GetRootLayer(), *tracker.take())
    if fragment is not None:
        apply(receiver, fragment)
    assert mirror.GetRootLayer().ExportToString() == receiver.GetRootLayer().ExportToString()
    return fragment


def _cube(stage, path, n=100, offset=0.0):
    xf = UsdGeom.Xform.Define(stage, path)
    xf.AddTranslateOp().Set(Gf.Vec3d(offset, 0, 0))
    mesh = UsdGeom.Mesh.Define(stage, path + "/mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.random.default_rng(1).random((n, 3), np.float32)))
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    return xf


def test_first_send_is_the_new_subtree_with_arrays_beside_the_text():
    mirror, tracker, receiver, _ = _pair()
    UsdGeom.SetStageUpAxis(mirror, UsdGeom.Tokens.z)
    _cube(mirror, "/root/a")
    fragment = _send(mirror, tracker, receiver)
    assert fragment["copy"] == ["/root"] and fragment["fields"] == ["/"]
    (path, t, kind, array), = fragment["arrays"]
    assert (path, t, kind, array.shape) == ("/root/a/mesh.points", None, "Vec3fArray", (100, 3))
    assert "points" in fragment["text"] and "0." not in fragment["text"].split("points")[1][:40]
    assert UsdGeom.GetStageUpAxis(receiver) == UsdGeom.Tokens.z


def test_a_transform_edit_sends_that_value_only():
    mirror, tracker, receiver, heard = _pair()
    for i in range(50):
        _cube(mirror, f"/root/c{i}", offset=i)
    _send(mirror, tracker, receiver)
    heard.take()
    mirror.GetAttributeAtPath("/root/c7.xformOp:translate").Set(Gf.Vec3d(7, 1, 0))
    fragment = _send(mirror, tracker, receiver)
    assert fragment["copy"] == ["/root/c7.xformOp:translate"] and not fragment["arrays"]
    assert size(fragment) < 300, size(fragment)
    assert heard.take() == (set(), {"/root/c7.xformOp:translate"})


def test_rewriting_a_subtree_sends_only_what_differs():
    """A prim written again in a scratch stage and copied over: unchanged values are
    not sent; a removed child and a removed property are."""
    mirror, tracker, receiver, heard = _pair()
    _cube(mirror, "/root/a")
    UsdGeom.Mesh.Define(mirror, "/root/a/extra")
    mirror.GetPrimAtPath("/root/a").CreateAttribute("old", Sdf.ValueTypeNames.Float).Set(1.0)
    _send(mirror, tracker, receiver)
    heard.take()
    scratch = Usd.Stage.CreateInMemory()
    _cube(scratch, "/root/a")
    points = scratch.GetAttributeAtPath("/root/a/mesh.points")
    moved = np.array(points.Get())
    moved[0] += 1
    points.Set(Vt.Vec3fArray.FromNumpy(moved))
    Sdf.CopySpec(scratch.GetRootLayer(), "/root/a", mirror.GetRootLayer(), "/root/a")
    fragment = _send(mirror, tracker, receiver)
    assert fragment["copy"] == ["/root/a/mesh.points"]
    assert fragment["remove"] == ["/root/a.old", "/root/a/extra"]
    resynced, changed = heard.take()
    assert resynced == {"/root/a.old", "/root/a/extra"} and changed == {"/root/a/mesh.points"}


def test_new_prims_metadata_and_time_samples():
    mirror, tracker, receiver, _ = _pair()
    _cube(mirror, "/root/a")
    _send(mirror, tracker, receiver)
    _cube(mirror, "/root/b", n=(ARRAY_MIN - 1) // 3)   # small arrays stay in the text
    attr = mirror.GetAttributeAtPath("/root/a/mesh.points")
    for t in (1.0, 2.0):
        attr.Set(Vt.Vec3fArray.FromNumpy(np.full((100, 3), t, np.float32)), t)
    mirror.GetPrimAtPath("/root/a").SetMetadata("kind", "component")
    mirror.SetEndTimeCode(2.0)
    fragment = _send(mirror, tracker, receiver)
    assert "/root/b" in fragment["copy"] and "/" in fragment["fields"]
    assert sorted(t for p, t, *_ in fragment["arrays"]
                  if p == "/root/a/mesh.points" and t is not None) == [1.0, 2.0]
    assert not [p for p, *_ in fragment["arrays"] if p.startswith("/root/b")]
    assert receiver.GetEndTimeCode() == 2.0


def test_nothing_changed_is_nothing_to_send():
    mirror, tracker, receiver, _ = _pair()
    _cube(mirror, "/root/a")
    _send(mirror, tracker, receiver)
    mirror.GetAttributeAtPath("/root/a.xformOp:translate").Set(Gf.Vec3d(0, 0, 0))  # same value
    assert encode(mirror.GetRootLayer(), *tracker.take()) is None
