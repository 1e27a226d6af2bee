"""Content the stage cannot hold yet: each kind either exports through its evaluated
mesh (or, hair curves, as curves) or is skipped with exactly one warning naming the
object and the reason, and the export never aborts. Meshes with no faces are skipped
with one warning."""
import numpy as np
import pytest


def _link(ob):
    import bpy
    bpy.context.scene.collection.objects.link(ob)
    return ob


def _hair_curves():
    import bpy
    curves = bpy.data.hair_curves.new("Hair")
    curves.add_curves([4, 4, 4])
    return _link(bpy.data.objects.new("HairCurves", curves))


def _volume():
    import bpy
    return _link(bpy.data.objects.new("Fog", bpy.data.volumes.new("Fog")))


def _grease_pencil():
    import bpy
    return _link(bpy.data.objects.new("Sketch", bpy.data.grease_pencils.new("Sketch")))


def _particle_hair():
    from _export_helpers import cube_object
    ob = cube_object("Furry")
    system = ob.modifiers.new("Fur", "PARTICLE_SYSTEM").particle_system
    system.settings.type = "HAIR"
    system.settings.count = 10
    return ob


def _metaball():
    import bpy
    data = bpy.data.metaballs.new("Blob")
    data.elements.new().radius = 1.0
    data.resolution = 0.4
    return _link(bpy.data.objects.new("Blob", data))


def _text():
    import bpy
    data = bpy.data.curves.new("Label", type="FONT")
    data.body = "Lantern"
    data.extrude = 0.05
    return _link(bpy.data.objects.new("Label", data))


def _faceless():
    import bpy
    mesh = bpy.data.meshes.new("Wire")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [(0, 1), (1, 2)], [])
    return _link(bpy.data.objects.new("Wire", mesh))


SKIPPED = {"volume": (_volume, "volumes are not supported"),
           "grease pencil": (_grease_pencil, "grease pencil are not supported"),
           "particle hair": (_particle_hair, "renders hair or paths, which are not supported"),
           "faceless mesh": (_faceless, "a mesh with no faces (3 vertices, 2 edges)")}
AS_MESH = {"metaball": _metaball, "text": _text}


@pytest.mark.parametrize("kind", sorted(SKIPPED))
def test_unsupported_content_is_skipped_with_one_warning(empty_scene, kind, hard_case):
    from _export_helpers import cube_object, export_current
    make, reason = SKIPPED[kind]
    ob = make()
    cube_object("Neighbour")
    stage, report = export_current()
    mentions = [w for w in report.warnings if f"'{ob.name}'" in w]
    hard_case(f"{kind}: warnings naming the object (exactly 1)", len(mentions), 1)
    assert len(mentions) == 1, report.warnings
    assert reason in mentions[0], mentions
    assert stage.GetPrimAtPath("/root/Neighbour/Neighbour_mesh"), "the export went on"
    assert not any("instance" in w for w in report.warnings), report.warnings


@pytest.mark.parametrize("kind", sorted(AS_MESH))
def test_metaballs_and_text_export_their_evaluated_mesh(empty_scene, kind):
    import bpy
    from pxr import UsdGeom
    from _export_helpers import evaluated_mesh_data, export_current, vectors
    ob = AS_MESH[kind]()
    stage, report = export_current()
    assert report.warnings == [], report.warnings  # no misleading "instances" warning
    meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    assert len(meshes) == 1
    points = np.array(UsdGeom.Mesh(meshes[0]).GetPointsAttr().Get())
    expected = evaluated_mesh_data(ob, lambda m: vectors(m.vertices, "co"))
    assert points.shape == expected.shape and np.abs(points - expected).max() == 0
    assert bpy.context.scene.objects[ob.name]


def test_hair_curves_export_as_curves_without_a_warning(empty_scene):
    from pxr import UsdGeom
    from _export_helpers import export_current
    _hair_curves()
    stage, report = export_current()
    assert report.warnings == [], report.warnings
    curves = UsdGeom.BasisCurves(stage.GetPrimAtPath("/root/HairCurves/Hair"))
    assert list(curves.GetCurveVertexCountsAttr().Get()) == [4, 4, 4]
    assert curves.GetBasisAttr().Get() == "catmullRom" and curves.GetWrapAttr().Get() == "pinned"


def test_everything_at_once_exports(empty_scene):
    from _export_helpers import export_current
    made = [make() for make, _ in SKIPPED.values()] + [make() for make in AS_MESH.values()] + \
        [_hair_curves()]
    stage, report = export_current()
    for ob in made:
        assert sum(f"'{ob.name}'" in w for w in report.warnings) <= 1, report.warnings
    assert len(report.warnings) == len(SKIPPED)
