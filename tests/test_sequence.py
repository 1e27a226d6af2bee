"""Sequences: `render_sequence` / `lantern render --frames`, one GL context and one
upload of geometry for all frames; animated transforms, cameras and lights read at
each frame."""
import subprocess
import sys

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux

from lantern.engine import RenderSettings, render_stage
from lantern.engine.api import render_sequence
from test_skinning import look, skel_stage

W, H = 64, 48


def test_sequence_frame_equals_single_frame_render():
    stage = skel_stage(4, influences=2, grid=10, rot_deg=80)
    look(stage, (2, -9, 4), (2, 0, 0))
    seq = dict(render_sequence(stage, 1, 3, RenderSettings(width=W, height=H)))
    assert sorted(seq) == [1.0, 2.0, 3.0]
    assert seq[1.0].stats["meshes_uploaded"] == 1
    assert seq[2.0].stats["meshes_uploaded"] == 0 and seq[3.0].stats["meshes_uploaded"] == 0
    for f in (1, 3):
        single = render_stage(stage, RenderSettings(width=W, height=H, frame=f)).rgba
        assert np.abs(seq[float(f)].rgba - single).max() == 0.0
    assert np.abs(seq[1.0].rgba - seq[3.0].rgba).max() > 0.05   # it does animate


def animated_stage():
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    cube = UsdGeom.Cube.Define(stage, "/box")  # not a Mesh: ignored by the engine
    mesh = UsdGeom.Mesh.Define(stage, "/plane")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    op = UsdGeom.Xformable(mesh).AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, 0), 1)
    op.Set(Gf.Vec3d(0.8, 0, 0), 3)
    cam = UsdGeom.Camera.Define(stage, "/cam")
    cop = UsdGeom.Xformable(cam).AddTranslateOp()
    cop.Set(Gf.Vec3d(0, 0, 6), 1)
    cop.Set(Gf.Vec3d(0, 0, 9), 3)
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr().Set(1.0, 1)
    sun.CreateIntensityAttr().Set(4.0, 3)
    del cube
    return stage


def test_animated_transform_camera_and_light_at_requested_frame():
    stage = animated_stage()
    s1 = render_stage(stage, RenderSettings(width=W, height=H, frame=1, transparent=True)).rgba
    s3 = render_stage(stage, RenderSettings(width=W, height=H, frame=3, transparent=True)).rgba
    cov1, cov3 = s1[..., 3] > 0, s3[..., 3] > 0
    # Camera pulled back: the plane covers less; moved along +X: its centre moved right.
    assert cov3.sum() < 0.7 * cov1.sum()
    cx1 = np.nonzero(cov1)[1].mean()
    cx3 = np.nonzero(cov3)[1].mean()
    assert cx3 > cx1 + 2
    # The sun is 4x brighter at frame 3.
    ratio = s3[cov3, 0].mean() / s1[cov1, 0].mean()
    assert 3.5 < ratio < 4.5, ratio
    # The sequence reads the same things per frame.
    seq = dict(render_sequence(stage, 1, 3, RenderSettings(width=W, height=H, transparent=True)))
    assert np.abs(seq[3.0].rgba - s3).max() == 0.0


def test_cli_frames_writes_numbered_images(tmp_path):
    stage = skel_stage(3)
    src = tmp_path / "skel.usda"
    stage.GetRootLayer().Export(str(src))
    out = tmp_path / "out" / "frame_####.png"
    proc = subprocess.run([sys.executable, "-m", "lantern", "render", str(src), "--frames", "1:3",
                           "--size", "32x24", "-o", str(out)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    bad = subprocess.run([sys.executable, "-m", "lantern", "render", str(src), "--frames", "1:3",
                          "-o", str(tmp_path / "x.png")], capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "####" in bad.stderr


def test_cli_frames_to_an_animated_gif(tmp_path):
    """A sequence as one looping preview: one GIF frame per rendered frame, each the
    sRGB encoding of that frame's render."""
    import imageio.v3 as iio
    from lantern.engine.image_io import to_srgb8
    stage = skel_stage(3)
    src = tmp_path / "skel.usda"
    stage.GetRootLayer().Export(str(src))
    gif = tmp_path / "preview.gif"
    proc = subprocess.run([sys.executable, "-m", "lantern", "render", str(src), "--frames", "1:3",
                           "--size", "32x24", "-o", str(gif)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    frames = iio.imread(gif, index=None)
    assert frames.shape[:3] == (3, 24, 32)
    single = render_stage(stage, RenderSettings(width=32, height=24, frame=2)).rgba
    # GIF palettes quantise colours: compare loosely against the exact sRGB frame.
    assert np.abs(frames[1][..., :3].astype(int) - to_srgb8(single)[..., :3].astype(int)).mean() < 3
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())
