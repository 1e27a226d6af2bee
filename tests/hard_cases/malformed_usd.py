"""A generator of damaged USD files and a harness that renders each with `lantern render`.

    python tests/hard_cases/malformed_usd.py OUTDIR     # writes the files, renders, prints a table

Each case starts from one small valid scene (a textured cube, a camera, lights, a
skinned mesh, render settings) and damages one thing. Each states what a serious tool
does with it: `error` (a clear one-line message and a non-zero exit status),
`warning` (renders, and says what it dropped or fixed), `either`, or `render` (odd
but valid input: renders, with or without a warning). The harness runs
`lantern render` (its `main`, with --debug so a traceback shows) on every file in a
worker process with a watchdog, and classifies what happened:

    error      non-zero exit, the last line "lantern render: <file>: <reason>"
    warning    exit 0, at least one "warning:" line, a finite image
    rendered   exit 0, no warning, a finite image that is not black
    black      exit 0, no warning, an all-black image: a silent failure
    nan        exit 0, non-finite pixels in the image
    traceback  an exception escaped (a bug)
    no-reason  non-zero exit with an empty or missing reason
    hang       no answer within the timeout
    crash      the process died (a signal)
"""
import json
import os
import pathlib
import struct
import subprocess
import sys
import zlib

import numpy as np

TIMEOUT = 60.0  # seconds a single file may take before it counts as a hang
SIZE = "32x18"


# --- the valid scene ------------------------------------------------------------------

def write_png(path, rgb, bits=8):
    """An 8- or 16-bit RGB PNG with the standard library (no imaging package needed)."""
    rgb = np.asarray(rgb, np.uint8 if bits == 8 else ">u2")
    height, width = rgb.shape[:2]
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(height))

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    header = struct.pack(">IIBBBBB", width, height, bits, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) +
                chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


CUBE_POINTS = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
CUBE_FACES = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]


def build_base(stage, folder):
    """The valid scene every case damages."""
    from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdRender, UsdShade, UsdSkel, Vt
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(1)
    root = UsdGeom.Xform.Define(stage, "/root")
    stage.SetDefaultPrim(root.GetPrim())

    write_png(os.path.join(folder, "tex.png"),
              np.indices((8, 8)).sum(0)[..., None].repeat(3, -1) % 2 * 200 + 30)
    material = UsdShade.Material.Define(stage, "/root/_materials/Mat")
    shader = UsdShade.Shader.Define(stage, "/root/_materials/Mat/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    reader = UsdShade.Shader.Define(stage, "/root/_materials/Mat/st")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    texture = UsdShade.Shader.Define(stage, "/root/_materials/Mat/Tex")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./tex.png")
    texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
        reader.ConnectableAPI(), "result")
    texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        texture.ConnectableAPI(), "rgb")
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.5)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")

    cube = UsdGeom.Xform.Define(stage, "/root/Cube")
    cube.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0))
    mesh = UsdGeom.Mesh.Define(stage, "/root/Cube/Mesh")
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in CUBE_POINTS]))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([4] * 6))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([i for f in CUBE_FACES for i in f]))
    mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(-1, -1, -1), Gf.Vec3f(1, 1, 1)]))
    mesh.CreateNormalsAttr(Vt.Vec3fArray([Gf.Vec3f(*np.sign(p) / np.sqrt(3)) for p in CUBE_POINTS]))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                 UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray([Gf.Vec2f(u, v) for _ in range(6)
                          for u, v in ((0, 0), (1, 0), (1, 1), (0, 1))]))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)

    rig = UsdSkel.Root.Define(stage, "/root/Rig")
    rig.AddTranslateOp().Set(Gf.Vec3d(3, 0, 0))
    skel = UsdSkel.Skeleton.Define(stage, "/root/Rig/Skel")
    skel.CreateJointsAttr(Vt.TokenArray(["A", "A/B"]))
    identity = Gf.Matrix4d(1)
    up = Gf.Matrix4d(1).SetTranslate(Gf.Vec3d(0, 0, 1))
    skel.CreateBindTransformsAttr(Vt.Matrix4dArray([identity, up]))
    skel.CreateRestTransformsAttr(Vt.Matrix4dArray([identity, up]))
    anim = UsdSkel.Animation.Define(stage, "/root/Rig/Skel/Anim")
    anim.CreateJointsAttr(Vt.TokenArray(["A", "A/B"]))
    anim.CreateTranslationsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(0, 0, 1)]))
    anim.CreateRotationsAttr(Vt.QuatfArray([Gf.Quatf(1, 0, 0, 0), Gf.Quatf(0.9239, 0.3827, 0, 0)]))
    anim.CreateScalesAttr(Vt.Vec3hArray([Gf.Vec3h(1, 1, 1), Gf.Vec3h(1, 1, 1)]))
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    skinned = UsdGeom.Mesh.Define(stage, "/root/Rig/Body")
    skinned.CreateSubdivisionSchemeAttr("none")
    skinned.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(x * 0.3, y * 0.3, (z + 1)) for x, y, z in CUBE_POINTS]))
    skinned.CreateFaceVertexCountsAttr(Vt.IntArray([4] * 6))
    skinned.CreateFaceVertexIndicesAttr(Vt.IntArray([i for f in CUBE_FACES for i in f]))
    skinned.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(-0.3, -0.3, 0), Gf.Vec3f(0.3, 0.3, 2)]))
    binding = UsdSkel.BindingAPI.Apply(skinned.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateJointIndicesPrimvar(False, 1).Set(Vt.IntArray([0, 0, 1, 1, 0, 0, 1, 1]))
    binding.CreateJointWeightsPrimvar(False, 1).Set(Vt.FloatArray([1.0] * 8))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1))

    camera = UsdGeom.Camera.Define(stage, "/root/Camera")
    view = Gf.Matrix4d().SetLookAt(Gf.Vec3d(6, -9, 5), Gf.Vec3d(1, 0, 0.5), Gf.Vec3d(0, 0, 1))
    camera.AddTransformOp().Set(view.GetInverse())
    camera.CreateFocalLengthAttr(35.0)
    camera.CreateHorizontalApertureAttr(36.0)
    camera.CreateVerticalApertureAttr(20.25)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))

    light = UsdLux.SphereLight.Define(stage, "/root/Light")
    light.AddTranslateOp().Set(Gf.Vec3d(2, -3, 4))
    light.CreateIntensityAttr(300.0)
    light.CreateRadiusAttr(0.1)
    light.CreateColorAttr(Gf.Vec3f(1, 0.9, 0.8))
    sun = UsdLux.DistantLight.Define(stage, "/root/Sun")
    sun.AddRotateXYZOp().Set(Gf.Vec3f(40, 10, 30))
    sun.CreateIntensityAttr(2.0)
    spot = UsdLux.SphereLight.Define(stage, "/root/Spot")
    spot.AddTranslateOp().Set(Gf.Vec3d(-2, -2, 4))
    spot.CreateIntensityAttr(200.0)
    shaping = UsdLux.ShapingAPI.Apply(spot.GetPrim())
    shaping.CreateShapingConeAngleAttr(30.0)
    rect = UsdLux.RectLight.Define(stage, "/root/Panel")
    rect.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    rect.CreateWidthAttr(1.0)
    rect.CreateHeightAttr(1.0)
    rect.CreateIntensityAttr(50.0)

    UsdGeom.Scope.Define(stage, "/Render")
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(32, 18))
    settings.CreateCameraRel().SetTargets([camera.GetPath()])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")


# --- damage ---------------------------------------------------------------------------

def _set(path, attr, value):
    def damage(stage, folder):
        stage.GetPrimAtPath(path).GetAttribute(attr).Set(value)
    return damage


def _points(transform):
    def damage(stage, folder):
        from pxr import Vt
        attr = stage.GetPrimAtPath("/root/Cube/Mesh").GetAttribute("points")
        p = np.array(attr.Get(), np.float32)
        attr.Set(Vt.Vec3fArray.FromNumpy(transform(p).astype(np.float32)))
    return damage


def _ints(path, attr, transform):
    def damage(stage, folder):
        from pxr import Vt
        a = stage.GetPrimAtPath(path).GetAttribute(attr)
        a.Set(Vt.IntArray([int(v) for v in transform(list(a.Get()))]))
    return damage


def _matrix(path, values):
    def damage(stage, folder):
        from pxr import Gf, UsdGeom
        xf = UsdGeom.Xformable(stage.GetPrimAtPath(path))
        xf.ClearXformOpOrder()
        xf.AddTransformOp().Set(Gf.Matrix4d(*values))
    return damage


def _op(path, kind, value):
    def damage(stage, folder):
        from pxr import UsdGeom
        xf = UsdGeom.Xformable(stage.GetPrimAtPath(path))
        xf.ClearXformOpOrder()
        getattr(xf, f"Add{kind}Op")().Set(value)
    return damage


def _texture_bytes(data):
    def damage(stage, folder):
        with open(os.path.join(folder, "tex.png"), "wb") as f:
            f.write(data(open(os.path.join(folder, "tex.png"), "rb").read()
                         if os.path.exists(os.path.join(folder, "tex.png")) else b""))
    return damage


def _texture_path(value):
    return _set("/root/_materials/Mat/Tex", "inputs:file", value)


def _reference(target_file=None, target_prim=None, text=None):
    """/root/Ref referencing a file (written with `text` when given) or a prim."""
    def damage(stage, folder):
        from pxr import Sdf
        prim = stage.DefinePrim("/root/Ref", "Xform")
        if text is not None:
            with open(os.path.join(folder, target_file), "w") as f:
                f.write(text)
        if target_file is not None:
            prim.GetReferences().AddReference(f"./{target_file}",
                                              Sdf.Path(target_prim) if target_prim else Sdf.Path())
        else:
            prim.GetReferences().AddInternalReference(target_prim)
    return damage


def _sublayer_cycle(stage, folder):
    name = os.path.basename(stage.GetRootLayer().identifier)
    with open(os.path.join(folder, "cycle_b.usda"), "w") as f:
        f.write(f'#usda 1.0\n(\n    subLayers = [@./{name}@]\n)\n')
    stage.GetRootLayer().subLayerPaths.append("./cycle_b.usda")


def _self_reference(stage, folder):
    name = os.path.basename(stage.GetRootLayer().identifier)
    prim = stage.DefinePrim("/root/Ref", "Xform")
    prim.GetReferences().AddReference(f"./{name}")


def _bytes(transform):
    """Damage applied to the written file's bytes."""
    transform.raw = True
    return transform


def _flip(seed, count):
    def damage(data):
        rng = np.random.default_rng(seed)
        b = bytearray(data)
        for i in rng.integers(len(b) // 4, len(b), count):
            b[i] ^= 0xFF
        return bytes(b)
    return _bytes(damage)


NAN, INF = float("nan"), float("inf")


def cases():
    """[(name, expect, usda or usdc, damage)]; damage(stage, folder) edits the valid
    stage before it is written, or (marked raw) transforms the written bytes."""
    from pxr import Gf, Vt
    c = []

    def add(name, expect, damage, fmt="usda"):
        c.append((name, expect, fmt, damage))

    # The file itself.
    for fmt in ("usda", "usdc"):
        for fraction in (0.0, 0.05, 0.3, 0.6, 0.9, 0.99):
            add(f"truncated_{fmt}_{int(fraction * 100):02d}", "either",
                _bytes(lambda d, f=fraction: d[:int(len(d) * f)]), fmt)
        for seed in range(3):
            add(f"bytes_flipped_{fmt}_{seed}", "either", _flip(seed, 20), fmt)
    add("garbage", "error", _bytes(lambda d: os.urandom(4096)))
    add("usdc_bytes_named_usda", "either", _bytes(lambda d: d), "usdc_as_usda")
    add("empty_layer", "render", _bytes(lambda d: b"#usda 1.0\n"))
    # Mesh topology.
    mesh = "/root/Cube/Mesh"
    add("counts_sum_too_big", "warning", _ints(mesh, "faceVertexCounts", lambda v: v[:-1] + [9]))
    add("counts_sum_too_small", "warning", _ints(mesh, "faceVertexCounts", lambda v: v[:-1]))
    add("count_zero", "warning", _ints(mesh, "faceVertexCounts", lambda v: [0] + v))
    add("count_two", "warning", _ints(mesh, "faceVertexCounts", lambda v: [2, 2] + v[1:]))
    add("count_negative", "warning", _ints(mesh, "faceVertexCounts", lambda v: [-4] + v[1:] + [8]))
    add("count_huge", "warning", _ints(mesh, "faceVertexCounts", lambda v: [2 ** 31 - 1] + v[1:]))
    add("index_out_of_range", "warning", _ints(mesh, "faceVertexIndices", lambda v: v[:-1] + [8]))
    add("index_huge", "warning", _ints(mesh, "faceVertexIndices", lambda v: [2 ** 31 - 1] + v[1:]))
    add("index_negative", "warning", _ints(mesh, "faceVertexIndices", lambda v: [-1] + v[1:]))
    add("no_points", "warning", _set(mesh, "points", Vt.Vec3fArray()))
    add("no_faces", "warning", _set(mesh, "faceVertexCounts", Vt.IntArray()))
    add("points_wrong_type", "either", _bytes(lambda d: d.replace(
        b"point3f[] points = [(-1", b'string points = "x"\n        float3[] junk = [(-1', 1)))
    # Non-finite geometry.
    add("point_nan", "warning", _points(lambda p: np.where(np.arange(len(p))[:, None] == 3, NAN, p)))
    add("point_inf", "warning", _points(lambda p: np.where(np.arange(len(p))[:, None] == 3, INF, p)))
    add("points_all_nan", "warning", _points(lambda p: p * NAN))
    add("point_minus_inf", "warning", _points(lambda p: np.where(np.arange(len(p))[:, None] == 0, -INF, p)))
    add("points_huge", "render", _points(lambda p: p * 1e30))
    add("points_float_max", "render", _points(lambda p: np.sign(p) * 3.4e38))
    add("normals_nan", "warning", _set(mesh, "normals", Vt.Vec3fArray([Gf.Vec3f(NAN, 0, 0)] * 8)))
    add("normals_zero", "render", _set(mesh, "normals", Vt.Vec3fArray([Gf.Vec3f(0, 0, 0)] * 8)))
    add("normals_count_wrong", "warning", _set(mesh, "normals", Vt.Vec3fArray([Gf.Vec3f(0, 0, 1)] * 3)))
    add("uv_nan", "warning", _set(mesh, "primvars:st", Vt.Vec2fArray([Gf.Vec2f(NAN, 0)] * 24)))
    add("uv_count_wrong", "warning", _set(mesh, "primvars:st", Vt.Vec2fArray([Gf.Vec2f(0, 0)] * 5)))
    add("extent_nan", "render", _set(mesh, "extent", Vt.Vec3fArray([Gf.Vec3f(NAN)] * 2)))
    add("interpolation_bogus", "warning", lambda s, f: s.GetPrimAtPath(mesh).GetAttribute(
        "primvars:st").SetMetadata("interpolation", "sideways"))
    # Transforms.
    add("xform_nan", "warning", _matrix("/root/Cube", [NAN] * 16))
    add("xform_inf", "warning", _matrix("/root/Cube", [INF] + [0] * 14 + [1]))
    add("xform_zero", "render", _matrix("/root/Cube", [0] * 15 + [1]))
    add("xform_translate_nan", "warning", _op("/root/Cube", "Translate", Gf.Vec3d(NAN, 0, 0)))
    add("xform_scale_zero", "render", _op("/root/Cube", "Scale", Gf.Vec3f(0, 0, 0)))
    add("xform_scale_nan", "warning", _op("/root/Cube", "Scale", Gf.Vec3f(NAN, 1, 1)))
    add("xform_orient_nan", "warning", _op("/root/Cube", "Orient", Gf.Quatf(NAN, 0, 0, 0)))
    add("xform_orient_zero", "render", _op("/root/Cube", "Orient", Gf.Quatf(0, 0, 0, 0)))
    add("xform_translate_huge", "warning", _op("/root/Cube", "Translate", Gf.Vec3d(1e300, 0, 0)))
    add("xform_op_order_missing_op", "render", lambda s, f: s.GetPrimAtPath("/root/Cube").GetAttribute(
        "xformOpOrder").Set(Vt.TokenArray(["xformOp:translate", "xformOp:rotateXYZ"])))
    # Cameras.
    camera = "/root/Camera"
    add("camera_vaperture_zero", "render", _set(camera, "verticalAperture", 0.0))  # aspect conforms it
    add("camera_clip_near_zero", "render", _set(camera, "clippingRange", Gf.Vec2f(0, 100)))
    for name, attr, value in (("focal_zero", "focalLength", 0.0), ("focal_negative", "focalLength", -35.0),
                              ("focal_nan", "focalLength", NAN), ("focal_inf", "focalLength", INF),
                              ("haperture_zero", "horizontalAperture", 0.0),
                              ("aperture_nan", "horizontalAperture", NAN),
                              ("aperture_negative", "verticalAperture", -20.0),
                              ("clip_nan", "clippingRange", Gf.Vec2f(NAN, 100)),
                              ("clip_reversed", "clippingRange", Gf.Vec2f(100, 0.1)),
                              ("clip_negative", "clippingRange", Gf.Vec2f(-1, -0.1)),
                              ("projection_bogus", "projection", "fisheye")):
        add(f"camera_{name}", "error", _set(camera, attr, value))
    add("camera_xform_nan", "error", _matrix(camera, [NAN] * 16))
    add("camera_xform_singular", "either", _matrix(camera, [0] * 15 + [1]))
    add("render_settings_camera_missing", "warning", lambda s, f: s.GetPrimAtPath(
        "/Render/Settings").GetRelationship("camera").SetTargets(["/root/Nowhere"]))
    add("render_settings_camera_not_camera", "warning", lambda s, f: s.GetPrimAtPath(
        "/Render/Settings").GetRelationship("camera").SetTargets(["/root/Cube"]))
    add("resolution_zero", "render", _set("/Render/Settings", "resolution", Gf.Vec2i(0, 0)))
    add("resolution_huge", "render", _set("/Render/Settings", "resolution", Gf.Vec2i(10 ** 6, 10 ** 6)))
    add("resolution_negative", "render", _set("/Render/Settings", "resolution", Gf.Vec2i(-32, 18)))
    # Textures.
    add("texture_corrupt_png", "warning", _texture_bytes(lambda d: b"\x89PNG\r\n\x1a\n" + os.urandom(200)))
    add("texture_truncated_png", "warning", _texture_bytes(lambda d: d[: len(d) // 2]))
    add("texture_empty_file", "warning", _texture_bytes(lambda d: b""))
    add("texture_missing", "warning", _texture_path("./nowhere.png"))
    add("texture_is_directory", "warning", _texture_path("."))
    add("texture_not_an_image", "warning", _texture_path("./tex_is_text.usda"))
    # Skeletons.
    skel, body = "/root/Rig/Skel", "/root/Rig/Body"
    add("bind_transforms_fewer", "warning", _set(skel, "bindTransforms", Vt.Matrix4dArray([Gf.Matrix4d(1)])))
    add("bind_transforms_more", "warning", _set(skel, "bindTransforms", Vt.Matrix4dArray([Gf.Matrix4d(1)] * 3)))
    add("bind_transform_singular", "warning", _set(skel, "bindTransforms",
                                                  Vt.Matrix4dArray([Gf.Matrix4d(0), Gf.Matrix4d(1)])))
    add("rest_transforms_fewer", "warning", _set(skel, "restTransforms", Vt.Matrix4dArray([Gf.Matrix4d(1)])))
    add("joint_index_out_of_range", "warning", _set(body, "primvars:skel:jointIndices",
                                                    Vt.IntArray([0, 0, 7, 1, 0, 0, 1, 1])))
    add("joint_indices_count_wrong", "warning", _set(body, "primvars:skel:jointIndices", Vt.IntArray([0, 1])))
    add("joint_weights_nan", "warning", _set(body, "primvars:skel:jointWeights", Vt.FloatArray([NAN] * 8)))
    add("joint_weights_zero", "render", _set(body, "primvars:skel:jointWeights", Vt.FloatArray([0.0] * 8)))
    add("anim_rotation_nan", "warning", _set(skel + "/Anim", "rotations",
                                             Vt.QuatfArray([Gf.Quatf(NAN, 0, 0, 0)] * 2)))
    add("anim_translations_fewer", "warning", _set(skel + "/Anim", "translations", Vt.Vec3fArray([Gf.Vec3f(0)])))
    add("skeleton_target_missing", "warning", lambda s, f: s.GetPrimAtPath(body).GetRelationship(
        "skel:skeleton").SetTargets(["/root/Nowhere"]))
    add("joints_empty", "warning", _set(skel, "joints", Vt.TokenArray()))
    # Lights.
    for name, path, attr, value in (("intensity_nan", "/root/Light", "inputs:intensity", NAN),
                                    ("intensity_inf", "/root/Light", "inputs:intensity", INF),
                                    ("intensity_negative", "/root/Light", "inputs:intensity", -100.0),
                                    ("color_nan", "/root/Light", "inputs:color", Gf.Vec3f(NAN, 1, 1)),
                                    ("radius_negative", "/root/Light", "inputs:radius", -1.0),
                                    ("radius_nan", "/root/Light", "inputs:radius", NAN),
                                    ("exposure_huge", "/root/Light", "inputs:exposure", 1e6),
                                    ("cone_nan", "/root/Spot", "inputs:shaping:cone:angle", NAN),
                                    ("cone_zero", "/root/Spot", "inputs:shaping:cone:angle", 0.0),
                                    ("rect_width_zero", "/root/Panel", "inputs:width", 0.0),
                                    ("rect_height_nan", "/root/Panel", "inputs:height", NAN),
                                    ("sun_angle_nan", "/root/Sun", "inputs:angle", NAN)):
        add(f"light_{name}", "warning", _set(path, attr, value))
    add("light_xform_nan", "warning", _matrix("/root/Light", [NAN] * 16))
    add("dome_texture_missing", "warning", lambda s, f: __import__("pxr").UsdLux.DomeLight.Define(
        s, "/root/Dome").CreateTextureFileAttr("./nowhere.exr"))
    add("dome_texture_corrupt", "warning", lambda s, f: (
        open(os.path.join(f, "dome.exr"), "wb").write(b"v/1\x01" + os.urandom(300)),
        __import__("pxr").UsdLux.DomeLight.Define(s, "/root/Dome").CreateTextureFileAttr("./dome.exr")))
    # Materials.
    surface = "/root/_materials/Mat/Surface"
    add("material_roughness_nan", "warning", _set(surface, "inputs:roughness", NAN))
    add("material_opacity_nan", "warning", lambda s, f: __import__("pxr").UsdShade.Shader(
        s.GetPrimAtPath(surface)).CreateInput("opacity", __import__("pxr").Sdf.ValueTypeNames.Float).Set(NAN))
    add("material_connection_missing", "warning", lambda s, f: __import__("pxr").UsdShade.Shader(
        s.GetPrimAtPath(surface)).GetInput("diffuseColor").GetAttr().SetConnections(
            ["/root/_materials/Mat/Nowhere.outputs:rgb"]))
    add("material_binding_missing", "warning", lambda s, f: __import__("pxr").UsdShade.MaterialBindingAPI(
        s.GetPrimAtPath(mesh)).GetDirectBindingRel().SetTargets(["/root/_materials/Nowhere"]))
    # Composition.
    add("reference_file_missing", "warning", _reference("nowhere.usda", "/root"))
    add("reference_prim_missing", "warning", _reference(target_prim="/root/Nowhere"))
    add("reference_corrupt_file", "warning", _reference("broken_ref.usda", "/root", "#usda 1.0\n(((garbage"))
    add("reference_cycle_self", "either", _self_reference)
    add("sublayer_cycle", "either", _sublayer_cycle)
    add("sublayer_missing", "warning", lambda s, f: s.GetRootLayer().subLayerPaths.append("./nowhere.usda"))
    add("payload_missing", "warning", lambda s, f: s.DefinePrim("/root/Payload").GetPayloads().AddPayload(
        "./nowhere.usda"))
    # Stage metadata.
    add("meters_per_unit_zero", "render", lambda s, f: __import__("pxr").UsdGeom.SetStageMetersPerUnit(s, 0.0))
    add("meters_per_unit_nan", "render", lambda s, f: s.SetMetadata("metersPerUnit", NAN))
    add("up_axis_bogus", "render", lambda s, f: s.SetMetadata("upAxis", "W"))
    add("time_codes_per_second_zero", "render", lambda s, f: s.SetTimeCodesPerSecond(0))
    add("start_after_end", "render", lambda s, f: (s.SetStartTimeCode(10), s.SetEndTimeCode(1)))
    # Points and instancers (drawn by the engine; never a crash).
    add("points_prim_nan", "warning", lambda s, f: __import__("pxr").UsdGeom.Points.Define(
        s, "/root/Cloud").CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(NAN)] * 3)))
    add("instancer_index_out_of_range", "warning", _instancer([0, 5]))
    add("instancer_no_prototypes", "warning", _instancer([0, 0], prototypes=False))
    add("instancer_positions_nan", "warning", _instancer([0, 0], positions=[(NAN, 0, 0), (1, 1, 1)]))
    return c


def _instancer(indices, prototypes=True, positions=((0, 0, 3), (1, 1, 3))):
    def damage(stage, folder):
        from pxr import Gf, UsdGeom, Vt
        pi = UsdGeom.PointInstancer.Define(stage, "/root/Instancer")
        if prototypes:
            pi.CreatePrototypesRel().SetTargets(["/root/Cube"])
        pi.CreateProtoIndicesAttr(Vt.IntArray(indices))
        pi.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in positions]))
    return damage


def generate(folder):
    """Writes every case into `folder`; returns {file name: (case name, expect)}."""
    from pxr import Usd
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = {}
    for name, expect, fmt, damage in cases():
        case_dir = folder / name
        case_dir.mkdir(exist_ok=True)
        real = "usdc" if fmt.startswith("usdc") else "usda"
        built = case_dir / f"{name}.{real}"
        stage = Usd.Stage.CreateNew(str(built))
        build_base(stage, str(case_dir))
        (case_dir / "tex_is_text.usda").write_text("#usda 1.0\n")
        raw = getattr(damage, "raw", False)
        if not raw:
            damage(stage, str(case_dir))
        stage.GetRootLayer().Save()
        del stage
        if raw:
            built.write_bytes(damage(built.read_bytes()))
        path = built
        if fmt == "usdc_as_usda":  # binary bytes behind a text extension
            path = built.with_suffix(".usda")
            built.rename(path)
        written[str(path.relative_to(folder))] = (name, expect)
    return written


# --- the harness ----------------------------------------------------------------------

def _classify(status, stderr, image_path):
    if status == "hang":
        return "hang", ""
    if isinstance(status, int) and status < 0:
        return "crash", f"signal {-status}"
    lines = [line for line in stderr.splitlines() if line.strip()]
    if "Traceback (most recent call last)" in stderr:
        return "traceback", lines[-1] if lines else ""
    if status != 0:
        last = lines[-1] if lines else ""
        reason = last.split(": ", 2)[-1].strip() if last.startswith("lantern render: ") else ""
        return ("error", last) if reason else ("no-reason", last)
    warnings = [line for line in lines if line.startswith("warning: ")]
    from lantern.engine.image_io import read_exr
    rgba = read_exr(str(image_path))
    if not np.isfinite(rgba).all():
        return "nan", f"{int((~np.isfinite(rgba)).sum())} non-finite values"
    if warnings:
        return "warning", warnings[0]
    if float(np.abs(rgba[..., :3]).max()) == 0.0:
        return "black", ""
    return "rendered", ""


def worker(out_dir, files):
    """Renders each file with lantern's own `main` in this process (so one GL context
    serves them all); one JSON line per file, a 'start' line before it."""
    import contextlib
    import io
    import traceback
    from lantern import cli
    for path in files:
        print(json.dumps({"start": path}), flush=True)
        image = os.path.join(out_dir, pathlib.Path(path).stem + ".exr")
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                status = cli.main(["render", path, "-o", image, "--size", SIZE, "--debug"])
            except SystemExit as exit_:
                status = exit_.code if isinstance(exit_.code, int) else 2
            except BaseException:
                traceback.print_exc()
                status = 1
        print(json.dumps({"file": path, "status": status, "stderr": err.getvalue(),
                          "image": image}), flush=True)


def run(files, out_dir, timeout=TIMEOUT):
    """{file: (outcome, detail)} for every file, each rendered once by a worker
    process; a file that takes longer than `timeout` is a hang (the worker is killed
    and a new one goes on with the next file), a worker that dies is a crash."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    results, pending = {}, list(files)
    while pending:
        proc = subprocess.Popen([sys.executable, __file__, "--worker", str(out_dir), *pending],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        import selectors
        selector = selectors.DefaultSelector()
        selector.register(proc.stdout, selectors.EVENT_READ)
        current = None
        while True:
            if not selector.select(timeout):
                proc.kill()
                results[current or pending[0]] = ("hang", f"no answer in {timeout:g} s")
                break
            line = proc.stdout.readline()
            if not line:
                proc.wait()
                if current is not None:
                    results[current] = ("crash", f"worker exit status {proc.returncode}")
                break
            message = json.loads(line)
            if "start" in message:
                current = message["start"]
                continue
            results[message["file"]] = _classify(message["status"], message["stderr"],
                                                 message["image"])
            current = None
        proc.stdout.close()
        pending = [f for f in pending if f not in results]
    return results


def allowed(expect):
    """Outcomes that meet an expectation; `render` is for valid, if odd, input."""
    return {"error": {"error"}, "warning": {"warning"}, "either": {"error", "warning"},
            "render": {"rendered", "warning"}}[expect]


def main(argv):
    if argv and argv[0] == "--worker":
        worker(argv[1], argv[2:])
        return 0
    folder = pathlib.Path(argv[0] if argv else "malformed_usd")
    written = generate(folder)
    results = run([str(folder / f) for f in sorted(written)], folder / "_images")
    counts = {}
    print("| file | expected | outcome | detail |\n|---|---|---|---|")
    for f in sorted(written):
        name, expect = written[f]
        outcome, detail = results[str(folder / f)]
        counts[outcome] = counts.get(outcome, 0) + 1
        mark = "" if outcome in allowed(expect) else " **(unexpected)**"
        print(f"| {name} | {expect} | {outcome}{mark} | {detail[:110].replace('|', '/')} |")
    print(f"\n{len(written)} files: " + ", ".join(f"{n} {k}" for k, n in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
