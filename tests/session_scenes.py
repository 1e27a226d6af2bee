"""Stages for the Session tests and bench/bench_session.py, built in memory with pxr:
many separate cubes (or the same cubes merged into one mesh) on a floor, with
optional shadow-casting lights and a camera; views around them."""
import math

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

import shadow_scenes

CUBE_POINTS = np.array([(x, y, z) for z in (-0.5, 0.5) for y in (-0.5, 0.5) for x in (-0.5, 0.5)])
CUBE_INDICES = [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5]


def material(stage, name, color):
    mat = UsdShade.Material.Define(stage, f"/root/_materials/{name}")
    sh = UsdShade.Shader.Define(stage, f"/root/_materials/{name}/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.6)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def grid_positions(n, spacing=1.6):
    side = int(math.ceil(math.sqrt(n)))
    return [((i % side - (side - 1) / 2) * spacing, (i // side - (side - 1) / 2) * spacing, 0.5)
            for i in range(n)]


def cubes_stage(n=1000, merged=False, lights=(), size=0.8, camera=True):
    """n cubes of side `size` in a square grid on a floor: each its own Xform + Mesh
    (its own points, so n meshes), or all in one Mesh when `merged`. Three materials
    alternate. lights: shadow_scenes light kinds ("point", "spot") placed above."""
    stage = shadow_scenes.new_stage(half=60.0)
    mats = [material(stage, name, c) for name, c in
            (("red", (0.8, 0.2, 0.1)), ("green", (0.2, 0.7, 0.2)), ("blue", (0.2, 0.3, 0.9)))]
    positions = grid_positions(n)
    if merged:
        pts = np.concatenate([CUBE_POINTS * size + p for p in positions])
        idx = np.concatenate([np.array(CUBE_INDICES) + 8 * i for i in range(n)])
        mesh = UsdGeom.Mesh.Define(stage, "/root/merged")
        mesh.CreateSubdivisionSchemeAttr("none")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
        mesh.CreateFaceVertexCountsAttr([4] * (6 * n))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(idx.astype(np.int32)))
        binding = UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim())
        binding.Bind(mats[0])
        for k, mat in enumerate(mats):           # the same materials, by face subsets
            faces = np.array([6 * i + f for i in range(k, n, 3) for f in range(6)], np.int32)
            subset = binding.CreateMaterialBindSubset(mat.GetPath().name, Vt.IntArray.FromNumpy(faces))
            UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(mat)
    else:
        points = Vt.Vec3fArray.FromNumpy((CUBE_POINTS * size).astype(np.float32))
        for i, p in enumerate(positions):
            xf = UsdGeom.Xform.Define(stage, f"/root/c{i:04d}")
            xf.AddTranslateOp().Set(Gf.Vec3d(*p))
            mesh = UsdGeom.Mesh.Define(stage, f"/root/c{i:04d}/mesh")
            mesh.CreateSubdivisionSchemeAttr("none")
            mesh.CreatePointsAttr(points)
            mesh.CreateFaceVertexCountsAttr([4] * 6)
            mesh.CreateFaceVertexIndicesAttr(CUBE_INDICES)
            UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mats[i % 3])
    extent = max(abs(c) for p in positions for c in p[:2]) + 1
    for kind in lights:
        if kind == "point":
            shadow_scenes.add_light(stage, "point", pos=(0.3 * extent, -0.2 * extent, 6.0),
                                    power=4000.0, radius=0.1)
        elif kind == "spot":
            shadow_scenes.add_light(stage, "spot", pos=(-0.4 * extent, 0.3 * extent, 9.0),
                                    aim=(0, 0, 0), power=9000.0, cone=40.0, softness=0.2)
    if camera:
        shadow_scenes.add_camera(stage, eye=(extent * 1.2, -extent * 1.5, extent * 1.1),
                                 target=(0, 0, 0), far=10 * extent)
    return stage


def orbit_views(stage, n, aspect, radius=None, height=None):
    """n (view, projection) pairs circling the stage's middle, OpenGL convention."""
    from lantern.core.transforms import frustum, look_at
    bound = UsdGeom.BBoxCache(Usd.TimeCode.Default(), ["default"]).ComputeWorldBound(
        stage.GetPseudoRoot()).ComputeAlignedRange()
    r = radius or 0.35 * float(np.linalg.norm(np.array(bound.GetSize())[:2]))
    h = height or 0.6 * r
    near, far = 0.1, 20 * r
    t = near * math.tan(math.radians(25))
    proj = frustum(-t * aspect, t * aspect, -t, t, near, far)
    views = []
    for k in range(n):
        a = 2 * math.pi * (k + 0.5) / n
        eye = np.array([r * math.cos(a), r * math.sin(a), h])
        views.append((np.linalg.inv(look_at(eye, np.zeros(3), np.array([0, 0, 1.0]))), proj))
    return views


def time_sampled_mesh_stage(frames=300, grid=100):
    """A grid mesh whose points are time-sampled at every frame (a baked deformation,
    the exporter's fallback), and a camera."""
    stage = shadow_scenes.new_stage(half=5.0)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(frames)
    xs, ys = np.meshgrid(np.linspace(-2, 2, grid), np.linspace(-2, 2, grid))
    rows, cols = np.meshgrid(np.arange(grid - 1), np.arange(grid - 1), indexing="ij")
    a = (rows * grid + cols).ravel()
    quads = np.stack([a, a + 1, a + grid + 1, a + grid], 1)
    mesh = UsdGeom.Mesh.Define(stage, "/root/wave")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(quads), 4, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.ravel().astype(np.int32)))
    attr = mesh.CreatePointsAttr()
    for f in range(1, frames + 1):
        z = 0.3 * np.sin(xs * 2 + f * 0.1) + 0.5
        pts = np.stack([xs.ravel(), ys.ravel(), z.ravel()], 1).astype(np.float32)
        attr.Set(Vt.Vec3fArray.FromNumpy(pts), f)
    shadow_scenes.add_camera(stage, eye=(4, -5, 4), target=(0, 0, 0.5))
    return stage
