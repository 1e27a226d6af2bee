"""Stages and probes for the engine's hard cases (camera and depth, shadows, lighting,
instancing, textures), built in memory with pxr.

`far_scene` is one small scene (a floor, three boxes, a sun and a shadowed point
light, a dome, a camera) that can be moved far from the origin and scaled: the
geometry and lights through /root's transform, the camera outside it (at the moved
and scaled eye, with its clipping range scaled), point-light intensities by scale²
so irradiance, and so the image, does not change.

`positions_from_depth` reads the G-buffer's depth back through lib.glsl's own
`position_from_depth`, by a probe pass slotted after the G-buffer pass."""
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

import shadow_scenes as S


def material(stage, name, color, **inputs):
    mat = UsdShade.Material.Define(stage, f"/root/_materials/{name}")
    sh = UsdShade.Shader.Define(stage, f"/root/_materials/{name}/surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(inputs.get("roughness", 1.0))
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(inputs.get("ior", 1.0))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def quad(stage, path, corners, mat=None, normal=None):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreatePointsAttr([Gf.Vec3f(*c) for c in corners])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if normal is not None:
        mesh.CreateNormalsAttr([Gf.Vec3f(*normal)] * 4)
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    if mat is not None:
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    return mesh


def camera(stage, path, eye, target, near, far, focal=35.0, hap=36.0, aspect=16 / 9,
           up=(0, 0, 1)):
    cam = UsdGeom.Camera.Define(stage, path)
    cam.CreateFocalLengthAttr(focal)
    cam.CreateHorizontalApertureAttr(hap)
    cam.CreateVerticalApertureAttr(hap / aspect)
    cam.CreateClippingRangeAttr(Gf.Vec2f(near, far))
    m = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(*up))
    cam.AddTransformOp().Set(m.GetInverse())
    return cam


def far_scene(offset=(0.0, 0.0, 0.0), scale=1.0, point=True, sun=True):
    stage = S.new_stage(half=6.0)
    S.add_box(stage, (0, 0, 0.5), 1.0, "box1")
    S.add_box(stage, (1.6, 0.8, 0.3), 0.6, "box2")
    S.add_box(stage, (-1.2, 1.0, 0.75), 1.5, "box3")
    if sun:
        S.add_light(stage, "sun", strength=1.5, dir=(0.7, 0.5, -0.6), angle=2.0)
    if point:
        S.add_light(stage, "point", pos=(1.5, -1.5, 2.5), power=300.0 * scale ** 2, radius=0.1)
    dome = UsdLux.DomeLight.Define(stage, "/root/dome")
    dome.CreateIntensityAttr(0.1)
    # Blender's AO distance is a length too: the scaled scene's is scaled with it.
    dome.GetPrim().CreateAttribute("lantern:aoDistance", Sdf.ValueTypeNames.Float).Set(10.0 * scale)
    root = UsdGeom.Xformable(stage.GetPrimAtPath("/root"))
    root.AddTranslateOp().Set(Gf.Vec3d(*offset))
    root.AddScaleOp().Set(Gf.Vec3d(scale, scale, scale))
    o = np.asarray(offset, np.float64)
    UsdGeom.Xform.Define(stage, "/view")
    camera(stage, "/view/cam", o + scale * np.array([6.0, -7.0, 4.0]),
           o + scale * np.array([0.0, 0.0, 0.5]), 0.05 * scale, 100.0 * scale, focal=20.0)
    return stage


# --- reading positions back through lib.glsl -----------------------------------------

_PROBE_FRAG = """
out vec4 frag;
uniform sampler2D g_depth;
uniform mat4 inv_view_proj;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(g_depth, px, 0).r;
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    frag = is_background(depth) ? vec4(0.0) : vec4(position_from_depth(uv, depth, inv_view_proj), 1.0);
}
"""


def _probe_pass():
    from lantern.engine.gpu.framegraph import Pass
    from lantern.engine.gpu.programs import load_source, set_uniform

    class Probe(Pass):
        """Camera-relative positions of the G-buffer's depth (w = 0: background), and
        the raw depth, read back."""
        name = "probe"
        reads = ("g_depth", "view")

        def __init__(self, ctx, programs):
            self.ctx, self.programs = ctx, programs
            lib = load_source("lib.glsl")
            self.prog = ctx.program(vertex_shader=load_source("fullscreen.vert"),
                                    fragment_shader="#version 330 core\n" + lib + _PROBE_FRAG)
            self.result = None

        def execute(self, frame, board):
            w, h = frame.size
            tex = self.ctx.texture((w, h), 4, dtype="f4")
            fbo = self.ctx.framebuffer([tex])
            fbo.use()
            board["g_depth"].use(0)
            self.prog["g_depth"].value = 0
            set_uniform(self.prog, "inv_view_proj", board["view"].inv_view_proj)
            self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND)
            vao = self.ctx.vertex_array(self.prog, [])
            vao.render(self.ctx.TRIANGLES, vertices=3)
            pos = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(h, w, 4)
            depth = np.frombuffer(board["g_depth"].read(), np.float32).reshape(h, w)
            self.result = (pos[::-1].copy(), depth[::-1].copy(), board["view"])
            for obj in (vao, fbo, tex):
                obj.release()

    return Probe


def positions_from_depth(stage, settings):
    """(camera-relative positions (H, W, 4), w = 1 where drawn; window depth (H, W);
    the frame's View), row 0 = top."""
    from lantern.engine import Session
    from lantern.engine.gpu.context import run_gl
    with Session(stage, settings) as session:
        renderer = session._renderer
        probe = run_gl(lambda gl: _probe_pass()(gl.ctx, gl.programs))
        passes = renderer.graph.passes
        passes.insert([p.name for p in passes].index("gbuffer") + 1, probe)
        try:
            session.render()
        finally:
            passes.remove(probe)
            run_gl(lambda gl: probe.prog.release())
        return probe.result


def pixel_rays(view, w, h):
    """Unit camera-relative directions through each pixel centre (H, W, 3), row 0 = top,
    in double precision from the camera's own matrices."""
    from lantern.engine.view import relative_view
    cam = view.camera
    inv = np.linalg.inv(np.asarray(cam.proj, np.float64) @ relative_view(cam))
    x = (np.arange(w) + 0.5) / w * 2 - 1
    y = ((np.arange(h) + 0.5) / h * 2 - 1)[::-1]
    X, Y = np.meshgrid(x, y)
    ndc = np.stack([X, Y, np.ones_like(X), np.ones_like(X)], -1)   # far plane
    p = ndc @ inv.T
    d = p[..., :3] / p[..., 3:4]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)
