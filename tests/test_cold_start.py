"""The cold path of `lantern render`: it imports only what the render uses, renders
several files in one process past a bad one, and --timings names its phases."""
import os
import subprocess
import sys

import numpy as np

# A cube seen by a camera, with Blender's colour management as the exporter writes it
# (docs/stage_contract.md): a display image goes through AgX, an .exr does not.
CUBE = """#usda 1.0
(
    defaultPrim = "root"
    upAxis = "Z"
    metersPerUnit = 1
    renderSettingsPrimPath = "/Render/Settings"
)
def Xform "root"
{
    def Mesh "Cube"
    {
        int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
        int[] faceVertexIndices = [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5]
        point3f[] points = [(-1, -1, -1), (1, -1, -1), (-1, 1, -1), (1, 1, -1), (-1, -1, 1), (1, -1, 1), (-1, 1, 1), (1, 1, 1)]
        uniform token subdivisionScheme = "none"
    }
    def Camera "Camera"
    {
        float focalLength = 35
        float horizontalAperture = 36
        float verticalAperture = 20.25
        float2 clippingRange = (0.1, 100)
        float3 xformOp:rotateXYZ = (70, 0, 30)
        double3 xformOp:translate = (4, -7, 4)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    }
}
def Scope "Render"
{
    def RenderSettings "Settings"
    {
        rel camera = </root/Camera>
        string lantern:viewTransform = "AgX"
    }
}
"""

# Runs the CLI with some modules made unimportable: a finder ahead of every other that
# refuses them, so that importing one fails the render.
GUARDED = """
import sys
BLOCKED = ("lantern.compare", "dask", "distributed", "PyOpenColorIO", "bokeh")
class Refuse:
    def find_spec(self, name, path=None, target=None):
        if any(name == b or name.startswith(b + ".") for b in BLOCKED):
            raise ImportError(f"a plain render imported {name}")
        return None
sys.meta_path.insert(0, Refuse())
from lantern.cli import main
raise SystemExit(main(sys.argv[1:]))
"""


def _lantern(*args, code=None):
    command = [sys.executable, "-c", code] if code else [sys.executable, "-m", "lantern"]
    return subprocess.run(command + list(args), capture_output=True, text=True)


def _cube(folder, name="cube.usda"):
    path = folder / name
    path.write_text(CUBE)
    return path


def test_a_plain_render_imports_neither_compare_dask_nor_opencolorio(tmp_path):
    scene = _cube(tmp_path)
    exr = tmp_path / "cube.exr"
    proc = _lantern("render", str(scene), "-o", str(exr), "--size", "32x18", code=GUARDED)
    assert proc.returncode == 0, proc.stderr
    from lantern.engine.image_io import read_exr
    assert read_exr(str(exr))[..., :3].max() > 0
    # The guard bites: the same scene to a .png goes through AgX, with OpenColorIO.
    proc = _lantern("render", str(scene), "-o", str(tmp_path / "cube.png"), "--size", "32x18",
                    code=GUARDED)
    assert proc.returncode == 1 and "PyOpenColorIO" in proc.stderr, proc.stderr


def test_several_files_render_in_one_command_past_a_bad_one(tmp_path):
    first = _cube(tmp_path, "first.usda")
    (tmp_path / "more").mkdir()
    second = _cube(tmp_path / "more", "second.usda")
    broken = tmp_path / "broken.usda"
    broken.write_text("#usda 1.0\ndef Xform \"root\" {\n  this is not USD\n")
    missing = tmp_path / "missing.usd"
    out = tmp_path / "images"
    proc = _lantern("render", str(first), str(broken), str(missing), str(second),
                    "-o", str(out) + os.sep, "--size", "32x18", "--timings")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert sorted(os.listdir(out)) == ["first.png", "second.png"]
    errors = proc.stderr.strip().splitlines()
    assert len(errors) == 2, proc.stderr
    assert "broken.usda" in errors[0] and "missing.usd" in errors[1]
    assert "2 rendered, 2 failed" in proc.stdout
    # One process, one context: the second file makes no program the first one made.
    assert proc.stdout.count("timings of") == 2
    compiled = [line for line in proc.stdout.splitlines() if "programs:" in line]
    assert compiled[1].split()[1:4:2] == ["0", "0"], proc.stdout
    import imageio.v3 as iio
    a, b = (iio.imread(out / name) for name in ("first.png", "second.png"))
    assert a.shape[:2] == (18, 32) and np.array_equal(a, b)
    # Several scenes need a folder: an image name is a usage error, before any work.
    proc = _lantern("render", str(first), str(second), "-o", str(tmp_path / "one.png"))
    assert proc.returncode == 2 and "folder" in proc.stderr, proc.stderr


def test_timings_name_the_phases_of_a_cold_render(tmp_path):
    proc = _lantern("render", str(_cube(tmp_path)), "-o", str(tmp_path / "cube.exr"),
                    "--size", "32x18", "--timings")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    passes = [line for line in lines if line.startswith("  first frame's heaviest passes")]
    phases = [line.strip().rsplit(None, 1)[0] for line in lines
              if line.startswith("  ") and line.strip()[-1].isdigit() and line not in passes]
    assert phases == ["process start to main", "imports", "stage open", "GL context",
                      "session setup", "scene read", "programs", "uploads", "first frame",
                      "encode and write", "wall"], proc.stdout
    assert len(passes) == 1 and "gbuffer" in passes[0], proc.stdout



def test_the_command_keeps_what_it_made_out_of_the_collections_at_exit(tmp_path):
    """Python's collections while it shuts down traced every object a render left (most
    of 0.1-0.2 s of a cold `lantern render`'s exit): `python -m lantern` freezes them
    (gc.freeze) once the command returns, whatever its outcome."""
    code = ("import gc, runpy, sys\n"
            "sys.argv = ['lantern', 'render', sys.argv[1], '-o', sys.argv[2]]\n"
            "try:\n"
            "    runpy.run_module('lantern', run_name='__main__')\n"
            "except SystemExit as done:\n"
            "    print(done.code, gc.get_freeze_count())\n")
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path / "missing.usda"),
                           str(tmp_path / "x.png")], capture_output=True, text=True, timeout=120)
    assert "no such file" in proc.stderr
    status, frozen = proc.stdout.split()
    assert status == "1" and int(frozen) > 0


def test_depth_textures_are_made_32_bit_float_at_once():
    """ModernGL makes DEPTH_COMPONENT24 textures; the context's loader
    (engine/gpu/depth.py FloatDepthLoader) has them made DEPTH_COMPONENT32F as they are
    allocated, multisampled ones with fixed sample places, so the engine's depth
    targets (the G-buffer's, the shadow maps: 64 MB in the demo's first frame) are
    allocated once, where re-specifying them made llvmpipe allocate and clear each
    twice."""
    import ctypes

    from lantern.engine.gpu.context import run_gl
    from lantern.engine.gpu.stencil import entry_points
    GL_TEXTURE_2D, GL_TEXTURE_2D_MULTISAMPLE = 0x0DE1, 0x9100
    GL_TEXTURE_INTERNAL_FORMAT, GL_TEXTURE_FIXED_SAMPLE_LOCATIONS = 0x1003, 0x9107
    GL_DEPTH_COMPONENT32F = 0x8CAC

    def formats(made):
        """{name: (internal format, fixed sample places or None)} of made(gl)'s textures."""
        def run(gl):
            fn = entry_points(gl.proc, {
                "glBindTexture": (None, ctypes.c_uint, ctypes.c_uint),
                "glGetTexLevelParameteriv": (None, ctypes.c_uint, ctypes.c_int, ctypes.c_uint,
                                             ctypes.POINTER(ctypes.c_int))})

            def query(tex, target, name):
                value = ctypes.c_int(-1)
                fn["glBindTexture"](target, tex.glo)
                fn["glGetTexLevelParameteriv"](target, 0, name, ctypes.byref(value))
                fn["glBindTexture"](target, 0)
                return value.value

            textures, release = made(gl)
            out = {}
            for name, tex in textures.items():
                target = GL_TEXTURE_2D_MULTISAMPLE if tex.samples else GL_TEXTURE_2D
                out[name] = (query(tex, target, GL_TEXTURE_INTERNAL_FORMAT),
                             query(tex, target, GL_TEXTURE_FIXED_SAMPLE_LOCATIONS)
                             if tex.samples else None)
            release()
            return out
        return run_gl(run)

    def modern_gl(gl):
        textures = {"plain": gl.ctx.depth_texture((64, 32)),
                    "4 samples": gl.ctx.depth_texture((64, 32), samples=4)}
        return textures, lambda: [t.release() for t in textures.values()]

    assert formats(modern_gl) == {"plain": (GL_DEPTH_COMPONENT32F, None),
                                  "4 samples": (GL_DEPTH_COMPONENT32F, 1)}

    def pool_targets(gl):
        from lantern.engine.gpu.resources import TargetPool
        pool = TargetPool(gl.ctx, None)
        return {fmt: pool.acquire((64, 32), fmt) for fmt in ("depth", "depth_ms4")}, \
            pool.release_all

    assert formats(pool_targets) == {"depth": (GL_DEPTH_COMPONENT32F, None),
                                     "depth_ms4": (GL_DEPTH_COMPONENT32F, 1)}
