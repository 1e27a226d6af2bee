"""The glossy bounce (engine/gpu/passes/reflections.py): surfaces reflect the lit scene.
A metal ball over a red plane lit by a sun under a black world; the ball's lower half
reflects the plane. Needs compute shaders (GL 4.3), as the ray tracer does."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

import shadow_scenes
from lantern.engine import RenderSettings, Session
from lantern.engine.bounces import DIRECT, Bounces

W, H, FOCAL, HAP = 64, 48, 50.0, 36.0
CENTRE, RADIUS, EYE = (0.0, 0.0, 0.6), 0.5, (0.0, -4.0, 1.2)


def _material(stage, name, color, metallic, roughness):
    mat = UsdShade.Material.Define(stage, f"/root/_materials/{name}")
    sh = UsdShade.Shader.Define(stage, f"/root/_materials/{name}/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    sh.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(metallic)
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def ball_over_red_plane(roughness):
    stage = shadow_scenes.new_stage(half=6.0)
    UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/root/plane")).Bind(
        _material(stage, "red", (0.8, 0.05, 0.05), 0.0, 1.0))
    ball = UsdGeom.Sphere.Define(stage, "/root/ball")
    ball.CreateRadiusAttr(RADIUS)
    ball.AddTranslateOp().Set(Gf.Vec3d(*CENTRE))
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(
        _material(stage, "metal", (0.9, 0.9, 0.9), 1.0, roughness))
    shadow_scenes.add_light(stage, "sun", strength=3.0, dir=(0.6, 0.3, -1.0))
    shadow_scenes.add_camera(stage, eye=EYE, target=CENTRE, focal=FOCAL, hap=HAP, aspect=W / H)
    UsdLux.DomeLight.Define(stage, "/root/dark").CreateIntensityAttr(0.0)   # a black world
    return stage


def lower_half(rgba):
    """The mean colour of the ball's lower half (its centre is the image's)."""
    radius = np.degrees(np.arcsin(RADIUS / np.linalg.norm(np.subtract(EYE, CENTRE))))
    r_px = np.tan(np.radians(radius)) * FOCAL / HAP * W
    y, x = np.mgrid[0:H, 0:W] + 0.5
    dx, dy = x - W / 2, y - H / 2                      # rows run down the image
    inside = (dx * dx + dy * dy < (0.8 * r_px) ** 2) & (dy > 0.2 * r_px)
    assert inside.sum() > 20
    return rgba[inside, :3].mean(axis=0)


def render(stage, bounces):
    with Session(stage, RenderSettings(width=W, height=H, bounces=bounces, preset="low")) as s:
        return s.render()


@pytest.mark.parametrize("roughness, bounces", [(0.0, Bounces()), (0.0, Bounces(12, 0, 4)),
                                                (1.0, Bounces())])
def test_a_metal_ball_on_a_plane_shows_the_planes_lit_colour(roughness, bounces):
    """A mirror reflects the lit plane whether or not a field exists (traced, read from the
    lit frame); a rough metal takes the field's light (full mode). Without bounces the
    ball shows the dome's reflection only (black here) and the sun's highlight."""
    stage = ball_over_red_plane(roughness)
    full = render(stage, bounces)
    direct = render(stage, DIRECT)
    assert "reflections" in full.stats["passes"]
    assert "reflections" not in direct.stats["passes"]
    if roughness == 0.0:
        assert lower_half(direct.rgba).max() < 0.01
    r, g, b = lower_half(full.rgba) - lower_half(direct.rgba)
    assert r > 0.05 and r > 4.0 * g and r > 4.0 * b


def test_without_compute_a_mirror_reflects_the_dome_only():
    """GL 3.3 and 4.1 (no compute shaders: no tracer): no glossy bounce, today's
    reflection of the dome. A GL 4.3 frame in raster form (compute=False) has it."""
    stage = ball_over_red_plane(0.0)
    settings = RenderSettings(width=W, height=H, bounces=Bounces(), preset="low", compute=False)
    with Session(stage, settings) as s:
        assert "reflections" in s.render().stats["passes"]
        from lantern.engine.gpu.context import run_gl
        run_gl(lambda gl: [setattr(p, "tracer", None) for p in s._renderer.graph.passes
                           if p.name == "reflections"])
        result = s.render()
    assert "reflections" not in result.stats["passes"]
    assert lower_half(result.rgba).max() < 0.01


def test_where_nothing_reflects_the_frame_is_kept_exactly():
    """The pass rewrites the frame from its copy (engine/gpu/lit_copy.py): the plane, which
    has no specular lobe (IOR 1), is the image without the glossy bounce bit for bit (a
    copy into the texture itself rounded the floats to 8 bits on llvmpipe); a scene where
    nothing has a lobe runs no pass."""
    stage = ball_over_red_plane(0.0)
    plane = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/red/surface"))
    plane.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    glossy, plain = render(stage, Bounces(12, 4, 4)), render(stage, Bounces(12, 4, 0))
    assert "reflections" in glossy.stats["passes"]
    radius = np.degrees(np.arcsin(RADIUS / np.linalg.norm(np.subtract(EYE, CENTRE))))
    r_px = np.tan(np.radians(radius)) * FOCAL / HAP * W
    y, x = np.mgrid[0:H, 0:W] + 0.5
    away = (x - W / 2) ** 2 + (y - H / 2) ** 2 > (1.5 * r_px) ** 2
    assert np.array_equal(glossy.rgba[away], plain.rgba[away])
    ball = UsdShade.Shader(stage.GetPrimAtPath("/root/_materials/metal/surface"))
    ball.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    ball.GetInput("metallic").Set(0.0)
    assert "reflections" not in render(stage, Bounces(12, 4, 4)).stats["passes"]


@pytest.mark.parametrize("roughness", [0.0, 0.3])
def test_under_a_uniform_dome_a_lone_ball_reflects_what_it_did(roughness):
    """Rays that escape bring the dome over the lobe, weighted as the dome's reflection
    was: a lone metal ball under a uniform dome (nothing else to reflect, no field) is
    today's image within 1%."""
    from pxr import Usd
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root")
    ball = UsdGeom.Sphere.Define(stage, "/root/ball")
    ball.CreateRadiusAttr(RADIUS)
    ball.AddTranslateOp().Set(Gf.Vec3d(*CENTRE))
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(
        _material(stage, "metal", (0.9, 0.6, 0.3), 1.0, roughness))
    shadow_scenes.add_camera(stage, eye=EYE, target=CENTRE, focal=FOCAL, hap=HAP, aspect=W / H)
    dome = UsdLux.DomeLight.Define(stage, "/root/sky")
    dome.CreateColorAttr(Gf.Vec3f(0.4, 0.5, 0.6))
    glossy = render(stage, Bounces(12, 0, 4))
    assert "reflections" in glossy.stats["passes"]
    np.testing.assert_allclose(lower_half(glossy.rgba), lower_half(render(stage, DIRECT).rgba),
                               rtol=0.01)


def test_the_render_passes_take_the_reflected_plane_in_glossind():
    """DiffDir + DiffInd + GlossDir + GlossInd + Env + Emit is the image (without FXAA
    or post) with the glossy bounce too. The mirror's reflection of the lit plane is
    indirect light, as in Cycles: GlossInd holds the plane's red, GlossDir only the
    sun's highlight and the black dome the escaped rays meet."""
    stage = ball_over_red_plane(0.0)
    names = frozenset({"DiffDir", "DiffInd", "GlossDir", "GlossInd", "Env", "Emit"})
    with Session(stage, RenderSettings(width=W, height=H, bounces=Bounces(), preset="low",
                                       passes=names, fxaa=False)) as s:
        result = s.render()
    assert "reflections" in result.stats["passes"]
    total = sum(result.passes[n][..., :3] for n in names)
    np.testing.assert_allclose(total, result.rgba[..., :3], atol=1e-4)
    r, g, b = lower_half(result.passes["GlossInd"])
    assert r > 0.05 and r > 4.0 * g and r > 4.0 * b     # the plane's red
    assert lower_half(result.passes["GlossDir"]).max() < 0.01


def test_the_lit_copys_levels_are_made_by_lantern_not_by_the_driver(monkeypatch):
    """The copy of the lit frame gets its mip levels from a program of Lantern's
    (shaders/lit_mips.comp, which the program cache keeps), not from glGenerateMipmap,
    for which llvmpipe builds a blit shader in every new process (0.15 s of a cold
    render's CPU). Each texel is the mean of the 2 x 2 above it; an odd last row or
    column is left out, and a side of 1 is not halved."""
    import ctypes

    import moderngl
    from lantern.engine.gpu.context import run_gl
    from lantern.engine.gpu.resources import TargetPool
    from lantern.engine.gpu.stencil import entry_points

    generated = []
    build = moderngl.Texture.build_mipmaps
    monkeypatch.setattr(moderngl.Texture, "build_mipmaps",
                        lambda self, *a, **k: (generated.append(self), build(self, *a, **k)))
    assert "reflections" in render(ball_over_red_plane(0.3), Bounces()).stats["passes"]
    assert generated == []
    from lantern.engine.gpu.lit_copy import LitCopy, level_sizes

    def levels(gl):
        fn = entry_points(gl.proc, {
            "glBindTexture": (None, ctypes.c_uint, ctypes.c_uint),
            "glGetTexImage": (None, ctypes.c_uint, ctypes.c_int, ctypes.c_uint, ctypes.c_uint,
                              ctypes.c_void_p)})
        out, pool = [], TargetPool(gl.ctx, None)    # framebuffers only
        for w, h in ((8, 6), (5, 3)):
            image = np.random.default_rng(w).random((h, w, 4)).astype(np.float32)
            frame = gl.ctx.texture((w, h), 4, image.tobytes(), dtype="f4")
            copy = LitCopy(gl.ctx, pool, gl.programs, gl.proc, compute=True)
            tex = copy.copy(frame)
            chain = [image]
            fn["glBindTexture"](0x0DE1, tex.glo)                        # GL_TEXTURE_2D
            for level, (lw, lh) in enumerate(level_sizes((w, h)), 1):
                held = np.zeros((lh, lw, 4), np.float32)
                fn["glGetTexImage"](0x0DE1, level, 0x1908, 0x1406, held.ctypes.data)
                chain.append(held)                                     # RGBA, FLOAT
            out.append(chain)
            copy.release()
            frame.release()
        pool.release_all()
        return out

    for chain in run_gl(levels):
        for above, level in zip(chain, chain[1:]):
            h, w = level.shape[:2]
            rows = np.minimum(2 * np.arange(h)[:, None] + [0, 1], above.shape[0] - 1)
            cols = np.minimum(2 * np.arange(w)[:, None] + [0, 1], above.shape[1] - 1)
            mean = above[rows[:, :, None, None], cols[None, None]].mean(axis=(1, 3))
            np.testing.assert_allclose(level, mean, rtol=1e-6, atol=1e-7)

