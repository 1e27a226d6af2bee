"""The skinning pass's two forms, one body (shaders/skinning.glsl): compute (GL 4.3,
RenderSettings.compute) and transform feedback (GL 3.3/4.1, compute=False) give the
same deformed vertices, within 1e-6 of the bounding-box diagonal: linear blend and
dual-quaternion skinning, blend shapes (with normal offsets), influences past 8 (the
per-point texture), the crowd (two meshes on one skeleton, surface normals gathered
on the GPU) and a skinned subdivision cage (its patches made from the skinned
points, then tessellated). The compute form reads no memory that nothing wrote, and
binds the store right on any storage-offset alignment."""
import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom

from lantern.engine import RenderSettings, Session
from lantern.engine.gpu.context import run_gl
from lantern.engine.gpu.passes import skinning
from skel_scenes import crowd_stage, skel_stage
from test_readback import JUNK, _garbage

SKEL = "usdskel/usd/usdSkel/testenv/testUsdSkelBakeSkinning"

BOUND = 1e-6


def _cage_stage():
    """skel_stage's grid as a Catmull-Clark cage: skinned, then tessellated."""
    stage = skel_stage(4, influences=2, grid=8, rot_deg=60)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/root/mesh"))
    mesh.CreateSubdivisionSchemeAttr("catmullClark")
    mesh.GetPrim().CreateAttribute("lantern:subdivisionRenderLevel", Sdf.ValueTypeNames.Int,
                                   custom=True).Set(2)
    return stage


SCENES = {                        # procedural: no corpus, no bpy (the GPU machine runs them)
    "influences16": lambda: skel_stage(24, influences=16),
    "dqs8": lambda: skel_stage(5, method="dualQuaternion", influences=6, scale=(1.5, 0.7, 1.2)),
    "crowd": crowd_stage,
}
USDSKEL_TESTS = ("lbs", "dqs", "blendshapes", "blendshapesWithNormals")


@pytest.fixture
def forms(monkeypatch):
    """Which form deformed each mesh: ["compute" | "feedback", ...] per render."""
    taken = []
    for name, form in (("_skin_compute", "compute"), ("_skin_feedback", "feedback")):
        original = getattr(skinning.SkinningPass, name)

        def spy(self, mesh, original=original, form=form):
            taken.append(form)
            return original(self, mesh)
        monkeypatch.setattr(skinning.SkinningPass, name, spy)
    return taken


def _deformed(stage, compute, times):
    """{time: {mesh path: (points, normals)}} as a session with `compute` skins them."""
    with Session(stage, RenderSettings(width=1, height=1, compute=compute)) as session:
        return {t: session.skinned_points(t) for t in times}


def _worst(a, b) -> float:
    """Largest difference of two skinned_points results: points over each mesh's
    bounding-box diagonal, unit normals as they are."""
    assert a.keys() == b.keys() and a
    worst = 0.0
    for path in a:
        (pa, na), (pb, nb) = a[path], b[path]
        diag = np.linalg.norm(pb.max(axis=0) - pb.min(axis=0))
        worst = max(worst, np.abs(pa - pb).max() / diag, np.abs(na - nb).max())
    return worst


def _both_forms_agree(stage, forms, name):
    t0, t1 = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    times = [float(t) for t in np.linspace(t0, t1, 3)]
    computed = _deformed(stage, True, times)
    assert forms and set(forms) == {"compute"}
    forms.clear()
    fed = _deformed(stage, False, times)
    assert forms and set(forms) == {"feedback"}
    worst = max(_worst(computed[t], fed[t]) for t in times)
    print(f"{name}: compute vs transform feedback, worst {worst:.2e}")
    assert worst <= BOUND
    rest = _deformed(stage, False, [t0])[t0]
    assert max(_worst(computed[t], rest) for t in times[1:]) > 1e-3 or \
        name == "blendshapesWithNormals"          # the rig moves something (that file: normals)


@pytest.mark.parametrize("name", USDSKEL_TESTS)
def test_compute_skinning_equals_transform_feedback_on_usdskel_tests(corpus, forms, name):
    _both_forms_agree(Usd.Stage.Open(str(corpus / SKEL / f"{name}.usda")), forms, name)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_compute_skinning_equals_transform_feedback(forms, name):
    _both_forms_agree(SCENES[name](), forms, name)


def test_crowd_images_are_equal_in_both_forms(forms):
    """The crowd under its two shadowed lights: the same image from either form, and
    a frame change deforms both meshes once."""
    stage = crowd_stage()
    images = {}
    for compute in (True, False):
        settings = RenderSettings(width=48, height=32, compute=compute, ambient_occlusion=False)
        with Session(stage, settings) as session:
            session.render(frame=1)
            result = session.render(frame=3)
        assert result.stats["meshes_skinned"] == 2
        images[compute] = result.rgba
    assert forms.count("compute") == forms.count("feedback") == 4
    assert np.abs(images[True] - images[False]).max() <= 1e-5


def test_a_skinned_cage_is_skinned_and_tessellated_alike(forms):
    stage = _cage_stage()
    out = {}
    for compute in (True, False):
        settings = RenderSettings(width=48, height=32, frame=3, compute=compute,
                                  tessellation_px=2.0)
        with Session(stage, settings) as s:
            result = s.render()
            r = s._renderer
            key = next(iter(r.tessellation.meshes))
            out[compute] = run_gl(lambda gl: (r.skinning.read(key), r.tessellation.read(key)))
        assert result.stats["meshes_skinned"] == 1 == result.stats["meshes_tessellated"]
    assert set(forms) == {"compute", "feedback"}
    for got, want in zip(out[True], out[False]):
        assert got.shape == want.shape and len(want)
        p = want[:, :3]
        diag = np.linalg.norm(p.max(axis=0) - p.min(axis=0))
        assert np.abs(got - want).max() / diag <= BOUND


@pytest.mark.parametrize("junk", sorted(JUNK))
def test_compute_skinning_reads_no_memory_that_nothing_wrote(forms, junk, monkeypatch):
    """Fresh buffers and textures holding junk (as a GPU driver may hand them out;
    llvmpipe's are zeros): the crowd and a cage deform as they do in clean memory."""
    stages = (crowd_stage(), _cage_stage())
    clean = [_deformed(stage, True, [2.0])[2.0] for stage in stages]
    _garbage(monkeypatch, junk)
    dirty = [_deformed(stage, True, [2.0])[2.0] for stage in stages]
    assert set(forms) == {"compute"}
    for a, b in zip(clean, dirty):
        assert _worst(a, b) == 0.0


def test_a_store_bound_from_an_aligned_texel_below_the_mesh(forms):
    """Drivers may align storage bindings to as much as 256 bytes (llvmpipe: 16): the
    store is then bound from below a mesh's first vertex and the shader starts that
    many texels in. The crowd's second mesh starts mid-block at that alignment."""
    stage = crowd_stage()
    with Session(stage, RenderSettings(width=1, height=1, compute=True)) as session:
        skinning_pass = session._renderer.skinning
        skinning_pass._align = 256
        got = session.skinned_points(2.0)
        geometry = session._renderer.geometry
        offsets = run_gl(lambda gl: [geometry.deform_target(key)[1]
                                     for key in skinning_pass.inputs])
    assert any(offset % 256 for offset in offsets), offsets
    assert set(forms) == {"compute"}
    assert _worst(got, _deformed(stage, False, [2.0])[2.0]) <= BOUND
