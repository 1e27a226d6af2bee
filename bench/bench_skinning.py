"""GPU skinning: frame time, per-frame CPU (Python) time and the skinning pass's GPU
time against skinned vertex count and character count, in both of the pass's forms:
compute (skin.comp, GL 4.3) and transform feedback (skin.vert, GL 3.3/4.1 and
RenderSettings(compute=False)). Prints a table; asserts nothing.

Each case is a scene of procedural characters: a grid mesh bound with 4 influences to
a 64-joint skeleton with an animated rotation per joint, rendered at 320x180 by one
Session per form, frame changes taking turns between the forms (the first frame,
upload and compile, left out); each figure is the fastest of 6, since other work on
a shared machine only ever adds time. "cpu read" is the time spent in Python reading
the frame (UsdSkel poses, blend weights, transforms). The skinning figures are the
pass's GPU time (timer queries); on llvmpipe the "GPU" is the CPU too, so frame time is
dominated by vertex shading at 1M vertices.

Each case runs with authored normals (skinned, as UsdSkel skins them) and without
(the deformed surface's own, gathered per point on the GPU each frame, as the baked
twin and Blender have them), each in both forms: the skinning pass's GPU time, and
compute's time over transform feedback's ("c/tf").

    python bench/bench_skinning.py [--quick]     # --quick: no 1M-point character"""
import sys
import time

import lantern.exporters  # noqa: F401  (Blender's pxr first)
import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

from lantern.engine import RenderSettings, Session

JOINTS = 64
FRAMES = 4
ROUNDS = 6


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


def stage_of(n_chars, verts_per_char, normals):
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    side = int(np.ceil(np.sqrt(n_chars)))
    drawn = sum(add_character(stage, k, verts_per_char, ((k % side) * 1.5, (k // side) * 1.5, 0),
                              normals) for k in range(n_chars))
    return stage, drawn


def case(stage, rounds):
    """{form: (frame ms, cpu read ms, skinning GPU ms)}, the fastest of `rounds` frame
    changes per form (None: compute, False: transform feedback), the forms taking
    turns so that load from other work on the machine falls on both alike."""
    sessions = {form: Session(stage, RenderSettings(width=320, height=180, compute=form))
                for form in (None, False)}
    seen = {form: [] for form in sessions}
    try:
        for session in sessions.values():
            session.render(frame=1)                 # upload and compile
        for r in range(rounds):
            frame = 2 + r % (FRAMES - 1)            # every render a new pose
            for form, session in sessions.items():
                res = session.render(frame=frame)
                seen[form].append((res.timings["total"], res.timings["load"],
                                   res.gpu_timings["skinning"]))
    finally:
        for session in sessions.values():
            session.close()
    return {form: tuple(1000 * min(v[i] for v in values) for i in range(3))
            for form, values in seen.items()}


CASES = [(1, 10_000), (1, 100_000), (1, 1_000_000), (10, 10_000), (100, 1_000), (100, 10_000)]


def main():
    quick = "--quick" in sys.argv[1:]
    print(f"{'chars':>6} {'points/char':>12} {'skinned verts':>14} {'frame ms':>10} "
          f"{'cpu read ms':>12} | {'skinning GPU ms':>15} {'tf':>7} {'c/tf':>5} | "
          f"{'+surface normals':>16} {'tf':>7} {'c/tf':>5} | {'frame x':>7}")
    for n_chars, pts in CASES:
        if quick and pts >= 1_000_000:
            continue
        t0 = time.perf_counter()
        row = {}
        for normals in (True, False):
            stage, drawn = stage_of(n_chars, pts, normals)
            for form, figures in case(stage, ROUNDS).items():
                row[normals, form] = figures
        frame_ms, cpu_ms, skin_c = row[True, None]
        skin_tf = row[True, False][2]
        surf_frame, _, surf_c = row[False, None]
        surf_tf = row[False, False][2]
        print(f"{n_chars:>6} {pts:>12,} {drawn:>14,} {frame_ms:>10.1f} {cpu_ms:>12.2f} | "
              f"{skin_c:>15.2f} {skin_tf:>7.2f} {skin_c / skin_tf:>5.2f} | "
              f"{surf_c:>16.2f} {surf_tf:>7.2f} {surf_c / surf_tf:>5.2f} | "
              f"{surf_frame / frame_ms:>7.2f}   (case {time.perf_counter() - t0:.0f} s)",
              flush=True)


if __name__ == "__main__":
    main()
