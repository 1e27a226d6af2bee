"""GPU skinning: frame time and per-frame CPU (Python) time against skinned vertex
count and character count. Prints a table; asserts nothing.

Each case is a sequence (render_sequence) of procedural characters: a grid mesh
bound with 4 influences to a 64-joint skeleton with an animated rotation per joint.
The first frame (upload, shader compile) is left out. "cpu" is the time spent in
Python reading the frame (UsdSkel poses, blend weights, transforms) plus the
renderer's Python work, i.e. the frame's wall time less the GPU-bound passes as
timed after ctx.finish(); on llvmpipe the "GPU" is the CPU too, so frame time is
dominated by vertex shading at 1M vertices.

Each case runs twice: with authored normals (skinned, as UsdSkel skins them), and
without (the deformed surface's own, gathered per point on the GPU each frame, as the
baked twin and Blender have them): the skinning pass's time (median) both ways, and
the ratio of frame times."""
import time

import lantern.exporters  # noqa: F401  (Blender's pxr first)
import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

from lantern.engine import RenderSettings
from lantern.engine.api import render_sequence

JOINTS = 64
FRAMES = 4


def add_character(stage, k, n_verts, offset, normals=False):
    root = UsdSkel.Root.Define(stage, f"/c{k}")
    UsdGeom.Xformable(root).AddTranslateOp().Set(Gf.Vec3d(*offset))
    skel = UsdSkel.Skeleton.Define(stage, f"/c{k}/skel")
    names = [f"j{i}" for i in range(JOINTS)]
    bind = [Gf.Matrix4d().SetTranslate(Gf.Vec3d(i / JOINTS, 0, 0)) for i in range(JOINTS)]
    skel.CreateJointsAttr(names)
    skel.CreateBindTransformsAttr(bind)
    skel.CreateRestTransformsAttr(bind)
    anim = UsdSkel.Animation.Define(stage, f"/c{k}/skel/anim")
    anim.CreateJointsAttr(names)
    anim.CreateTranslationsAttr([Gf.Vec3f(i / JOINTS, 0, 0) for i in range(JOINTS)])
    anim.CreateScalesAttr([Gf.Vec3h(1, 1, 1)] * JOINTS)
    rot = anim.CreateRotationsAttr()
    for t in range(1, FRAMES + 2):
        a = 0.3 * t
        rot.Set([Gf.Quatf(float(np.cos(a / 2)), Gf.Vec3f(0, float(np.sin(a / 2)), 0))] * JOINTS, t)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    UsdSkel.BindingAPI.Apply(root.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])

    cols = max(2, int(np.sqrt(n_verts)))
    rows = max(2, n_verts // cols)
    xs, ys = np.meshgrid(np.linspace(0, 1, cols), np.linspace(-0.5, 0.5, rows))
    pts = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], 1)
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    a = (r * cols + c).ravel()
    quads = np.stack([a, a + 1, a + cols + 1, a + cols], 1)
    mesh = UsdGeom.Mesh.Define(stage, f"/c{k}/mesh")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(quads), 4, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.ravel().astype(np.int32)))
    if normals:
        up = np.tile(np.float32([0, 0, 1]), (len(pts), 1))
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(up))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    j = np.clip((pts[:, 0] * JOINTS).astype(np.int32)[:, None] + np.arange(4)[None] - 1, 0, JOINTS - 1)
    w = np.full((len(pts), 4), 0.25, np.float32)
    b = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    b.CreateJointIndicesPrimvar(False, 4).Set(Vt.IntArray.FromNumpy(j.ravel()))
    b.CreateJointWeightsPrimvar(False, 4).Set(Vt.FloatArray.FromNumpy(w.ravel()))
    return len(quads) * 6       # soup vertices drawn (two triangles per quad)


def case(n_chars, verts_per_char, normals):
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    side = int(np.ceil(np.sqrt(n_chars)))
    drawn = sum(add_character(stage, k, verts_per_char, ((k % side) * 1.5, (k // side) * 1.5, 0),
                              normals) for k in range(n_chars))
    frames, cpu, skinning = [], [], []
    for i, (_, res) in enumerate(render_sequence(stage, 1, FRAMES, RenderSettings(width=320, height=180))):
        if i == 0:
            continue                       # upload and compile
        t = res.timings
        frames.append(t["total"])
        cpu.append(t["load"])
        skinning.append(t["skinning"])
    return drawn, np.median(frames) * 1000, np.median(cpu) * 1000, np.median(skinning) * 1000


def main():
    print(f"{'chars':>6} {'points/char':>12} {'skinned verts':>14} {'frame ms':>10} "
          f"{'cpu read ms':>12} {'skinning ms':>12} {'+surface normals':>17} "
          f"{'frame x':>8}")
    for n_chars, pts in [(1, 10_000), (1, 100_000), (1, 1_000_000), (10, 10_000), (100, 1_000),
                         (100, 10_000)]:
        t0 = time.perf_counter()
        drawn, frame_ms, cpu_ms, skin_ms = case(n_chars, pts, normals=True)
        _, surface_ms, _, surface_skin_ms = case(n_chars, pts, normals=False)
        print(f"{n_chars:>6} {pts:>12,} {drawn:>14,} {frame_ms:>10.1f} {cpu_ms:>12.2f} "
              f"{skin_ms:>12.1f} {surface_skin_ms:>17.1f} {surface_ms / frame_ms:>8.2f}"
              f"   (case {time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
