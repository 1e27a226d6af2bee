"""GPU skinning: frame time, per-frame CPU (Python) time and the skinning pass's GPU
time against skinned vertex count and character count, in both of the pass's forms:
compute (skin.comp, GL 4.3) and transform feedback (skin.vert, GL 3.3/4.1 and
RenderSettings(compute=False)). Prints a table; asserts nothing.

Each case is a scene of procedural characters: a grid mesh bound with 4 influences to
a 64-joint skeleton with an animated rotation per joint, rendered at 320x180 (frame
changes, the form switched by Session.configure(compute=...), taking turns; the first
frames, upload and compile, left out). Each figure is the fastest of 6, since other
work on a shared machine only ever adds time. "frame" and "cpu read" (the time spent
in Python reading the frame: UsdSkel poses, blend weights, transforms) are compute's.
The skinning figures time the pass alone, both forms on the same meshes, between two
glFinish (case()); on llvmpipe the "GPU" is the CPU too, so frame time is dominated by
vertex shading at 1M vertices.

Each case runs with authored normals (skinned, as UsdSkel skins them) and without
(the deformed surface's own, gathered per point on the GPU each frame, as the baked
twin and Blender have them), each in both forms: the skinning pass's GPU time, and
compute's time over transform feedback's ("c/tf").

    python bench/bench_skinning.py [--quick]     # --quick: no 1M-point character"""
import sys
import time

try:
    import lantern.exporters  # noqa: F401  (where bpy is, Blender's pxr first)
except ImportError:           # no bpy (the GPU machine): usd-core's pxr
    pass
import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

from lantern.engine import RenderSettings, Session
from lantern.engine.gpu.context import run_gl

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
    mesh.CreateSubdivisionSchemeAttr("none")
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
    """{form: (frame ms, cpu read ms, skinning ms)} per form (None: compute, False:
    transform feedback), each the fastest of `rounds`, the forms taking turns so that
    load from other work on the machine falls on both alike. The frame is a frame
    change (every render a new pose); the skinning figure is the pass alone on the
    same meshes, between two glFinish: GL timestamps cannot time it on llvmpipe,
    whose timestamps are taken by its rasteriser threads, not where vertex and compute
    work runs."""
    frames = {form: [] for form in (None, False)}
    passes = {form: [] for form in frames}
    with Session(stage, RenderSettings(width=320, height=180)) as session:
        renderer = session._renderer               # the pass alone: a bench may look in
        for k in range(2 * (rounds + 1)):
            form = (None, False)[k % 2]
            session.configure(compute=form)
            res = session.render(frame=1 + k % (FRAMES + 1))   # keyed 1..FRAMES + 1
            if k >= 2:                              # the first of each: programs made
                frames[form].append((res.timings["total"], res.timings["load"]))
        meshes = [session.scene.meshes[key] for key in renderer.skinning.inputs]

        def skin(gl, compute):
            gl.ctx.finish()
            t0 = time.perf_counter()
            renderer.skinning._deform(meshes, compute)
            gl.ctx.finish()
            return time.perf_counter() - t0
        for _ in range(rounds):
            for form in passes:
                passes[form].append(run_gl(lambda gl: skin(gl, form is None)))
    return {form: (1000 * min(f[0] for f in frames[form]),
                   1000 * min(f[1] for f in frames[form]), 1000 * min(passes[form]))
            for form in frames}


CASES = [(1, 10_000), (1, 100_000), (1, 1_000_000), (10, 10_000), (100, 1_000), (100, 10_000)]


def main():
    quick = "--quick" in sys.argv[1:]
    print(f"{'chars':>6} {'points/char':>12} {'skinned verts':>14} {'frame ms':>10} "
          f"{'cpu read ms':>12} | {'skinning ms':>11} {'tf':>7} {'c/tf':>5} | "
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
              f"{skin_c:>11.2f} {skin_tf:>7.2f} {skin_c / skin_tf:>5.2f} | "
              f"{surf_c:>16.2f} {surf_tf:>7.2f} {surf_c / surf_tf:>5.2f} | "
              f"{surf_frame / frame_ms:>7.2f}   (case {time.perf_counter() - t0:.0f} s)",
              flush=True)


if __name__ == "__main__":
    main()
