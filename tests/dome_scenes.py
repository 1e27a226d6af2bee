"""Spheres under a dome map, built in memory with pxr (tests/test_dome_reflections.py),
and what they should reflect, integrated in numpy without any of the engine's tables.

The stage: a grid of smooth mesh spheres (one row per material, one column per
roughness) under a DomeLight with a lat-long map, seen by an orthographic camera (so
every pixel's view direction is the same). The dome is left untransformed, so its own
+Y (the map's top) is world +Y, and the camera looks at the spheres from 10 degrees
above that horizon, up = +Y: the image's upper half of each sphere faces the sky.

The reference: the lobe's mean radiance, the integral of L(l) F D G / (4 n.v) over the
light directions, over the same without L (the lobe's albedo), as Cycles' GGX
microfacet lobe (height-correlated Smith, its multiple-scattering factor a constant
over the lobe, so it cancels), by visible-normal sampling (Heitz 2018) on a Hammersley
set rotated per pixel."""
import math

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from lantern.engine.lighting import hammersley   # a point set, not one of its tables

ROUGHNESS = (0.05, 0.3, 0.6, 1.0)
MATERIALS = {"metal": dict(metallic=1.0, ior=1.5), "dielectric": dict(metallic=0.0, ior=1.5)}
SPACING = 2.5                 # between sphere centres (radius 1)
ELEVATION = 10.0              # the camera's height above the dome's horizon, degrees
PIXELS_PER_UNIT = 24
SKY, GROUND = (0.25, 0.45, 1.0), (0.35, 0.22, 0.08)


def latlong(kind, width=512):
    """(H, W, 4) float32 lat-long map in UsdLux's convention (row 0 is +Y): 'uniform'
    (radiance 1) or 'two-colour' (SKY above the horizon, GROUND below)."""
    h = width // 2
    rgba = np.ones((h, width, 4), np.float32)
    if kind == "two-colour":
        upper = (np.arange(h) + 0.5) < h / 2
        rgba[..., :3] = np.where(upper[:, None, None], SKY, GROUND)
    elif kind == "quadratic":
        theta = (np.arange(h) + 0.5) / h * math.pi
        phi = (np.arange(width) + 0.5) / width * 2 * math.pi - math.pi / 2
        t, p = np.meshgrid(theta, phi, indexing="ij")
        d = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1)
        rgba[..., :3] = quadratic(d)
    return rgba


def quadratic(d):
    """A radiance that order-2 harmonics hold exactly (by colour: up, sideways, both)."""
    y, x = d[..., 1:2], d[..., 0:1]
    return 1.0 + np.array([0.6, 0.0, 0.3]) * y + np.array([0.0, 0.4, 0.3]) * (x * x - y * y)


def write_map(path, kind):
    from lantern.engine.image_io import write_image
    write_image(str(path), latlong(kind))
    return str(path)


def sphere_mesh(stage, path, centre, material, segments=96, rings=48):
    theta = np.linspace(0.0, math.pi, rings + 1)
    phi = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    counts, indices = [], []
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            indices += [a, a + segments, b + segments, b]
            counts.append(4)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([Gf.Vec3f(*(np.asarray(centre) + q)) for q in n])
    mesh.CreateNormalsAttr([Gf.Vec3f(*q) for q in n])
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateFaceVertexCountsAttr(counts)
    mesh.CreateFaceVertexIndicesAttr(indices)
    mesh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    # Closed: a blended sphere shows its near side only (as Blender's Backface Culling).
    mesh.GetPrim().CreateAttribute("lantern:backfaceCulling", Sdf.ValueTypeNames.Bool).Set(True)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def material(stage, name, roughness, metallic, ior, opacity=1.0):
    mat = UsdShade.Material.Define(stage, f"/root/_materials/{name}")
    sh = UsdShade.Shader.Define(stage, f"/root/_materials/{name}/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((1, 1, 1))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    sh.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(metallic)
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(ior)
    if opacity < 1.0:
        sh.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(opacity)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def stage_with(map_path, opacity=1.0):
    """The sphere grid under a dome showing `map_path`, the spheres' opacity
    `opacity` (below 1: blended, drawn by the transparency pass); returns
    (stage, (w, h))."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Xform.Define(stage, "/root")
    for row, (name, params) in enumerate(MATERIALS.items()):
        for col, r in enumerate(ROUGHNESS):
            mat = material(stage, f"{name}{col}", r, opacity=opacity, **params)
            sphere_mesh(stage, f"/root/{name}{col}", centre(row, col), mat)
    dome = UsdLux.DomeLight.Define(stage, "/root/dome")
    dome.CreateTextureFileAttr(Sdf.AssetPath(map_path))
    dome.CreateIntensityAttr(1.0)
    width_m, height_m = SPACING * len(ROUGHNESS), SPACING * len(MATERIALS)
    cam = UsdGeom.Camera.Define(stage, "/root/cam")
    cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    cam.CreateHorizontalApertureAttr(width_m * 10)
    cam.CreateVerticalApertureAttr(height_m * 10)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    target = Gf.Vec3d(*centre(0.5, 0.5 * (len(ROUGHNESS) - 1)))
    e = math.radians(ELEVATION)
    eye = target + Gf.Vec3d(0.0, math.sin(e), math.cos(e)) * 20.0
    look = Gf.Matrix4d().SetLookAt(eye, target, Gf.Vec3d(0, 1, 0))
    cam.AddTransformOp().Set(look.GetInverse())
    return stage, (int(width_m * PIXELS_PER_UNIT), int(height_m * PIXELS_PER_UNIT))


def mirror_ball_stage():
    """A white mirror ball (radius 1) resting on a large white Lambert plane (z = 0,
    Z up) under a uniform dome of radiance 1, seen by an orthographic camera from
    above and in front, the ball in the image's upper half (the plane it reflects lies
    in front of it, on screen below it); returns (stage, (w, h), view direction
    towards the camera)."""
    import shadow_scenes as ss
    stage = ss.new_stage(half=40.0)
    sphere_mesh(stage, "/root/ball", (0.0, 0.0, 1.0), material(stage, "mirror", 0.0, 1.0, 1.5))
    UsdLux.DomeLight.Define(stage, "/root/dome").CreateIntensityAttr(1.0)
    eye, target = np.array([0.0, -10.0, 4.0]), np.array([0.0, 0.0, -0.5])
    ss.add_camera(stage, eye, target, aspect=1.0, ortho_width=6.0)
    v = (eye - target) / np.linalg.norm(eye - target)
    return stage, (128, 128), v


def centre(row, col):
    """Sphere centres on a plane facing the camera (tilted by its elevation)."""
    e = math.radians(ELEVATION)
    up = np.array([0.0, math.cos(e), -math.sin(e)])
    return np.array([col * SPACING, 0.0, 0.0]) - row * SPACING * up


def view_direction():
    """Towards the camera, world (the dome's) frame."""
    e = math.radians(ELEVATION)
    return np.array([0.0, math.sin(e), math.cos(e)])


def sphere_masks(result, shrink=0.9):
    """{(row, col): (upper-half mask, lower-half mask)} of each sphere's pixels within
    `shrink` of its radius on screen (its silhouette's pixels mix with the background)."""
    h, w = result.rgba.shape[:2]
    y, x = np.mgrid[0:h, 0:w]
    x = (x + 0.5) / PIXELS_PER_UNIT
    y = (y + 0.5) / PIXELS_PER_UNIT
    masks = {}
    for row in range(len(MATERIALS)):
        for col in range(len(ROUGHNESS)):
            cx, cy = (col + 0.5) * SPACING, (row + 0.5) * SPACING
            inside = (x - cx) ** 2 + (y - cy) ** 2 < shrink ** 2
            masks[row, col] = (inside & (y < cy), inside & (y >= cy))
    return masks


# --- the integral ------------------------------------------------------------------------

def _smith_lambda(c, a2):
    c = np.clip(c, 1e-7, 1.0)
    return 0.5 * (np.sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0)


def fresnel_dielectric(c, eta):
    g = np.sqrt(np.maximum(eta * eta - 1.0 + c * c, 0.0))
    a, b = (g - c) / (g + c), (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return 0.5 * a * a * (1.0 + b * b)


def lobe_mean(radiance, n, v, roughness, ior=None, samples=2048, seed=1):
    """(P, 3): the mean of radiance(l) (a function of (..., 3) unit directions) over the
    GGX lobe of perceptual roughness that normals n (P, 3) reflect towards v (3,),
    weighted by F D G / (4 n.v) (F = 1, or a dielectric's exact Fresnel at `ior`)."""
    a = max(roughness * roughness, 2e-3)
    a2 = a * a
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    helper = np.where(np.abs(n[:, 1:2]) < 0.99, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    tx = np.cross(helper, n)
    tx /= np.linalg.norm(tx, axis=-1, keepdims=True)
    ty = np.cross(n, tx)
    vl = np.stack([tx @ v, ty @ v, n @ v], -1)                        # (P, 3), local
    vl[:, 2] = np.maximum(vl[:, 2], 1e-4)
    vl /= np.linalg.norm(vl, axis=-1, keepdims=True)
    u1, u2 = hammersley(samples)
    shift = np.random.default_rng(seed).random((len(n), 2))
    u1 = (u1[None] + shift[:, :1]) % 1.0
    u2 = (u2[None] + shift[:, 1:]) % 1.0
    # Visible normals of the stretched view (Heitz 2018, "Sampling the GGX
    # Distribution of Visible Normals").
    vh = np.stack([a * vl[:, 0], a * vl[:, 1], vl[:, 2]], -1)
    vh /= np.linalg.norm(vh, axis=-1, keepdims=True)
    lensq = vh[:, 0] ** 2 + vh[:, 1] ** 2
    t1 = np.where(lensq[:, None] > 1e-12,
                  np.stack([-vh[:, 1], vh[:, 0], 0 * lensq], -1) / np.sqrt(np.maximum(lensq, 1e-30))[:, None],
                  [[1.0, 0.0, 0.0]])
    t2 = np.cross(vh, t1)
    rad, phi = np.sqrt(u1), 2 * math.pi * u2
    p1, p2 = rad * np.cos(phi), rad * np.sin(phi)
    s = 0.5 * (1.0 + vh[:, 2:3])
    p2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + s * p2
    p3 = np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))
    nh = p1[..., None] * t1[:, None] + p2[..., None] * t2[:, None] + p3[..., None] * vh[:, None]
    h = np.stack([a * nh[..., 0], a * nh[..., 1], np.maximum(nh[..., 2], 1e-7)], -1)
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    voh = np.sum(vl[:, None] * h, -1)
    l = 2.0 * voh[..., None] * h - vl[:, None]
    nol, nov = l[..., 2], vl[:, 2:3]
    # The estimator's weight under visible-normal sampling: G2 / G1(v).
    lv = _smith_lambda(nov, a2)
    weight = np.where(nol > 0, (1.0 + lv) / (1.0 + lv + _smith_lambda(nol, a2)), 0.0)
    if ior is not None:
        weight = weight * fresnel_dielectric(np.clip(voh, 0.0, 1.0), ior)
    world = l[..., :1] * tx[:, None] + l[..., 1:2] * ty[:, None] + l[..., 2:] * n[:, None]
    return np.einsum("psc,ps->pc", radiance(world), weight) / weight.sum(1)[:, None]


def lookup(image):
    """The radiance of a lat-long map (UsdLux's convention) towards directions (..., 3),
    bilinearly interpolated between texel centres, as a renderer reads it."""
    h, w = image.shape[:2]

    def radiance(d):
        u = ((np.arctan2(d[..., 2], d[..., 0]) + 0.5 * math.pi) / (2 * math.pi)) % 1.0 * w - 0.5
        t = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / math.pi * h - 0.5
        u0, t0 = np.floor(u).astype(int), np.floor(t).astype(int)
        fu, ft = (u - u0)[..., None], (t - t0)[..., None]
        rows = np.clip(t0, 0, h - 1), np.clip(t0 + 1, 0, h - 1)
        cols = u0 % w, (u0 + 1) % w
        top = image[rows[0], cols[0], :3] * (1 - fu) + image[rows[0], cols[1], :3] * fu
        bottom = image[rows[1], cols[0], :3] * (1 - fu) + image[rows[1], cols[1], :3] * fu
        return top * (1 - ft) + bottom * ft
    return radiance
