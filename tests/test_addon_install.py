"""The extension as users get it: `make extension`'s zip, checked by Blender's own
extension code, installed into a bpy process that hides every module a real Blender
lacks, in that process and in the engine host's child process (tests/_addon_host.py,
tests/blender_only/), and used there: the engine process, F12, view layers, border
and crop, transparent film, resolution %, an animation, a killed engine, progress,
material previews, and disable / re-enable / reinstall / uninstall."""
import json
import os
import pathlib
import subprocess
import sys
import tomllib
import zipfile
from unittest import mock

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent

WIDTH, HEIGHT = 64, 36
MANIFEST = tomllib.loads((REPO / "blender_manifest.toml").read_text())
# Blender versions that install extensions, with the Python each one runs.
BLENDERS = {(4, 2, 0): (3, 11, 9), (5, 0, 0): (3, 11, 13), (5, 1, 0): (3, 13, 5)}
# Blender's platform names, and what sysconfig.get_platform() says on each.
PLATFORMS = {"linux-x64": "linux-x86_64", "windows-x64": "win-amd64",
             "macos-arm64": "macosx-11.0-arm64", "macos-x64": "macosx-10.13-x86_64"}


@pytest.fixture(scope="session")
def extension_zip():
    """`make extension`: build and validate with Blender's extension tool."""
    proc = subprocess.run(["make", "--no-print-directory", "extension"], cwd=REPO,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "Success parsing TOML" in proc.stdout  # `blender_ext.py validate` ran
    path = REPO / "dist" / f"lantern-{MANIFEST['version']}.zip"
    assert path.is_file()
    return path


# --- the zip and Blender's compatibility logic -----------------------------------------

def test_zip_holds_only_what_the_extension_needs(extension_zip):
    with zipfile.ZipFile(extension_zip) as z:
        names = z.namelist()
    top = {n.split("/")[0] for n in names}
    code = {"__init__.py", "addon", "engine", "exporters", "shaders"} | (
        {"core"} if (REPO / "core").is_dir() else set())
    assert top == code | {"blender_manifest.toml", "wheels"}, top
    assert sorted(n for n in names if n.startswith("wheels/")) == \
        sorted(w.removeprefix("./") for w in MANIFEST["wheels"])
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    wheels = " ".join(MANIFEST["wheels"])
    assert "usd_core" not in wheels and "imageio" not in wheels  # Blender ships pxr, OIIO


def _blender_check(manifest, blender, python, platform):
    """What Blender does before installing a zip and when it enables the extension:
    bl_pkg's compatibility filter (Blender version, platform, the Python versions the
    wheels support), then its wheel filter for this system. Returns (error, wheels)."""
    from bl_pkg import bl_extension_ops, bl_extension_utils
    python_versions = bl_extension_utils.python_versions_from_wheels(manifest.wheels)
    error = bl_extension_utils.pkg_manifest_params_compatible_or_error(
        blender_version_min=manifest.blender_version_min,
        blender_version_max=manifest.blender_version_max or "",
        platforms=manifest.platforms,
        python_versions=[".".join(map(str, v)) for v in python_versions],
        this_platform=platform, this_blender_version=blender, this_python_version=python,
        error_fn=print)
    with mock.patch("sysconfig.get_platform", return_value=PLATFORMS.get(platform, platform)), \
            mock.patch.object(sys, "version_info", python):
        wheels = bl_extension_ops._extensions_wheel_filter_for_this_system(manifest.wheels)
    return error, sorted(os.path.basename(w).split("-")[0] for w in wheels)


def _zip_manifest(path):
    from bl_pkg.cli import blender_ext
    with zipfile.ZipFile(path) as z:
        manifest = blender_ext.pkg_manifest_from_zipfile_and_validate(
            z, blender_ext.pkg_zipfile_detect_subdir_or_none(z), strict=True)
    assert not isinstance(manifest, str), manifest
    return manifest


@pytest.mark.parametrize("blender", BLENDERS, ids=lambda v: ".".join(map(str, v[:2])))
@pytest.mark.parametrize("platform", PLATFORMS)
def test_blender_accepts_the_zip(extension_zip, blender, platform):
    """Every Blender from 4.2 to 5.1 on the four platforms accepts the zip, and
    enabling it finds exactly one moderngl and one glcontext wheel."""
    error, wheels = _blender_check(_zip_manifest(extension_zip), blender, BLENDERS[blender],
                                   platform)
    assert error is None, error
    assert wheels == ["glcontext", "mapbox_earcut", "moderngl"]


@pytest.mark.parametrize("blender, python, platform, refused", [
    ((4, 1, 0), (3, 11, 7), "linux-x64", "minimum supported version"),
    ((5, 1, 0), (3, 12, 0), "linux-x64", "Python version"),
    ((5, 0, 0), (3, 11, 13), "linux-arm64", "platform"),
])
def test_blender_refuses_what_the_zip_does_not_support(extension_zip, blender, python, platform,
                                                        refused):
    """The same check fails where it should, so the test above can fail."""
    error, wheels = _blender_check(_zip_manifest(extension_zip), blender, python, platform)
    assert error is not None and refused in error


# --- installed in a bpy that has only what Blender has -----------------------------------

@pytest.fixture(scope="module")
def installed(extension_zip, corpus, tmp_path_factory):
    """Runs tests/_addon_host.py once; (report, out dir)."""
    from lantern.demo.build_scene import build
    out = tmp_path_factory.mktemp("installed")
    demo = out / "demo.blend"
    build(str(demo), rigged=True)
    proc = subprocess.run(
        [sys.executable, str(REPO / "tests" / "_addon_host.py"), str(extension_zip), str(out),
         str(corpus), str(demo)],
        capture_output=True, text=True, timeout=600)
    report_path = out / "report.json"
    assert proc.returncode == 0 and report_path.is_file(), \
        f"the bpy host failed ({proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    report = json.loads(report_path.read_text())
    for name, step in report["steps"].items():
        print(f"{name}: {step['seconds']:.2f} s")
    for name, render in report["renders"].items():
        print(f"F12 {name}: {render['seconds']:.3f} s")
    return report, out


def _step(installed, name):
    step = installed[0]["steps"][name]
    assert step["ok"], f"{name}: {step['error']}\n{step['traceback']}"
    return step["value"]


def _image(installed, name):
    """A render's EXR (row 0 = top), after checking the render raised nothing."""
    from lantern.engine.image_io import read_exr
    report, out = installed
    render = report["renders"][name]
    assert "error" not in render, render["error"]
    return read_exr(render["file"])


def _sane(image):
    assert np.isfinite(image).all(), "non-finite pixels"
    assert image[..., :3].max() > 0.01, "black image"


def test_installs_with_what_blender_has(installed):
    assert _step(installed, "hidden_modules") == {"importable": []}
    info = _step(installed, "install")
    assert info["result"] == ["FINISHED"] and info["enabled"]
    user = info["user_dir"]
    assert info["package_file"].startswith(user)            # the add-on from the zip
    assert info["moderngl"].startswith(os.path.join(user, "extensions", ".local"))  # its wheel
    assert info["pxr"].startswith(info["blender_pxr_dir"])  # Blender's own USD
    print(f"install: {info['seconds']:.2f} s")


def test_the_engine_runs_in_its_own_process_from_the_installed_extension(installed):
    """The host process runs Blender's Python on the installed package, Blender's USD
    and the extension's wheels, with its own GL; Blender's process loads no GL module."""
    install = _step(installed, "install")
    host = _step(installed, "engine_process")
    user = install["user_dir"]
    assert host["running"] and host["info"]["pid"] in host["children"]
    assert host["info"]["executable"] == host["executable"]      # Blender's own Python
    modules = host["info"]["modules"]
    assert modules["lantern"] == install["package_file"]           # the installed add-on
    assert modules["pxr"].startswith(install["blender_pxr_dir"])   # Blender's USD
    for wheel in ("moderngl", "glcontext"):
        assert modules[wheel].startswith(os.path.join(user, "extensions", ".local")), modules
    assert host["info"]["gl"].startswith("OpenGL")
    assert host["gl_in_blender"] == []
    assert host["segments"], "frames come back through shared memory"


@pytest.mark.parametrize("name", ["lights", "suzanne", "rig"])
def test_f12_renders_corpus_scenes(installed, name):
    _step(installed, "corpus")
    image = _image(installed, name)
    assert image.shape == (HEIGHT, WIDTH, 4)
    _sane(image)


def test_f12_renders_the_textured_rigged_demo(installed):
    _step(installed, "corpus")
    _sane(_image(installed, "demo"))


def test_each_view_layer_renders_its_own_collections(installed):
    """Layer A shows only the sphere (left), layer B only the cube (right)."""
    from multilayer_exr import read_parts
    _step(installed, "view_layers")
    render = installed[0]["renders"]["layers"]
    assert "error" not in render, render["error"]
    layers = read_parts(render["file"])
    a, b = layers["LayerA.Combined"], layers["LayerB.Combined"]
    covered_a = np.nonzero(a[..., 3].max(axis=0) > 0)[0]
    covered_b = np.nonzero(b[..., 3].max(axis=0) > 0)[0]
    assert len(covered_a) and covered_a.max() < WIDTH // 2
    assert len(covered_b) and covered_b.min() > WIDTH // 2


def test_border_fills_only_the_border_and_crop_cuts_it(installed):
    _step(installed, "film_border_resolution")
    full, border, crop = (_image(installed, n) for n in ("full", "border", "crop"))
    # Border 0.1-0.45 x 0.2-0.8 of 64x36: Blender truncates to pixels 6-28 x 7-28 (y up).
    x0, y0, x1, y1 = 6, 7, 28, 28
    rows, cols = slice(HEIGHT - y1, HEIGHT - y0), slice(x0, x1)
    assert crop.shape == (y1 - y0, x1 - x0, 4)
    assert border.shape == full.shape
    inside = np.zeros(full.shape[:2], bool)
    inside[rows, cols] = True
    assert full[inside][:, :3].max() > 0.01 and (full[~inside][:, :3] > 0.01).any()
    np.testing.assert_allclose(border[inside], full[inside], atol=1e-6)
    assert not border[~inside].any()
    np.testing.assert_allclose(crop, full[rows, cols], atol=1e-6)


def test_transparent_film_gives_alpha(installed):
    _step(installed, "film_border_resolution")
    opaque, clear = _image(installed, "full"), _image(installed, "transparent")
    assert (opaque[..., 3] == 1.0).all()
    alpha = clear[..., 3]
    assert (alpha == 0).mean() > 0.5 and (alpha == 1).sum() > 100
    assert not clear[alpha == 0][:, :3].any()  # premultiplied: nothing where nothing is
    # Where the surface covers the pixel the colours are the same; at anti-aliased
    # edges the transparent one is premultiplied by its partial coverage.
    np.testing.assert_allclose(clear[alpha == 1][:, :3], opaque[alpha == 1][:, :3], atol=1e-6)


def test_resolution_percentage(installed):
    _step(installed, "film_border_resolution")
    half = _image(installed, "half")
    assert half.shape == (HEIGHT // 2, WIDTH // 2, 4)
    _sane(half)


def test_a_ten_frame_animation_renders(installed):
    from lantern.engine.image_io import read_exr
    anim = _step(installed, "animation")
    assert anim["files"] == [f"frame_{i:04d}.exr" for i in range(1, 11)]
    frames = [read_exr(str(installed[1] / "anim" / f)) for f in anim["files"]]
    for frame in frames:
        assert frame.shape == (HEIGHT, WIDTH, 4)
        _sane(frame)
    assert np.abs(frames[0] - frames[-1]).max() > 1e-3  # the rig moved
    print(f"10 frames: {anim['seconds']:.2f} s")


def test_stats_and_errors_reach_blender(installed):
    info = _step(installed, "stats_and_errors")
    assert {"Exporting the scene", "Rendering"} <= set(info["stats"])
    assert any(s.startswith("Done in") for s in info["stats"])


def test_a_killed_engine_is_reported_and_the_next_render_recovers(installed):
    info = _step(installed, "stats_and_errors")
    assert "Lantern: the engine process stopped (killed by SIGKILL)" in info["error"]
    assert info["recovered"] is None
    first, second = info["pids"]
    assert first != second
    _sane(_image(installed, "recovered"))


def test_material_previews_render_with_lantern(installed):
    info = _step(installed, "material_preview")
    assert info["scene_engine"] == "LANTERN"
    assert [c["preset"] for c in info["calls"]] == ["low", "low", "low"]
    assert {c["scene"] for c in info["calls"]} == {"preview"}
    assert all(c["size"] == [128, 128] for c in info["calls"])
    red, blue, network = (np.load(installed[1] / f"preview_{n}.npy")
                          for n in ("red", "blue", "network"))
    for image in (red, blue, network):
        _sane(image)
    # The sphere fills the middle of the preview; its colour is the material's.
    mid = slice(48, 80)
    r, b = red[mid, mid, :3].mean(axis=(0, 1)), blue[mid, mid, :3].mean(axis=(0, 1))
    assert r[0] > 1.5 * r[2] and b[2] > 1.5 * b[0], (r, b)
    # A node network's preview shows the network: both checker colours on the sphere
    # (Generated coordinates), not the Base Color socket's grey.
    px = network[mid, mid, :3].reshape(-1, 3)
    reddish, bluish = (px[:, 0] > 1.5 * px[:, 2]).mean(), (px[:, 2] > 1.5 * px[:, 0]).mean()
    assert reddish > 0.15 and bluish > 0.15, (reddish, bluish)
    print("preview seconds:", info["seconds"])


def _gl_driver_threads(names):
    """Mesa's rasteriser and shader-cache threads: with the engine in its own process,
    Blender's process has none."""
    return sorted(n for n in names if n.startswith("llvmpipe") or "disk$" in n)


HOST_THREADS = ["lantern-host-log", "lantern-host-read", "lantern-host-write"]


def test_disable_reenable_reinstall_uninstall_leave_nothing(installed):
    report = installed[0]
    life = _step(installed, "lifecycle")
    assert life["before_disable"] == HOST_THREADS
    assert len(life["children_before_disable"]) == 1 and life["segments_before_disable"]
    assert _gl_driver_threads(life["native_before_disable"]) == []
    disabled = life["after_disable"]
    assert not disabled["enabled"]
    assert not [t for t in disabled["python_threads"] if t.startswith("lantern")]
    assert disabled["child_processes"] == [] and disabled["segments"] == []
    assert life["reenabled_render"] is None and life["reinstalled_render"] is None
    assert life["after_reinstall"] == HOST_THREADS  # one host, not one per install
    assert len(life["children_after_reinstall"]) == 1
    gone = life["after_uninstall"]
    assert not gone["enabled"]
    assert not [t for t in gone["python_threads"] if t.startswith("lantern")]
    assert gone["child_processes"] == [] and gone["segments"] == []
    assert _gl_driver_threads(gone["native_threads"]) == []
    # Nothing of Lantern's is left anywhere in the home: the engine process's program
    # cache lived in the extension's own user folder, which Blender removed with it.
    # Blender's own cache of repository compatibility is Blender's, rewritten on change.
    extensions = os.path.join(report["user_dir"], "extensions")
    left = [f for f in gone["files"] if not f.startswith(os.path.join(extensions, ".cache"))]
    assert left == report["baseline"]["files"]
    programs = [f for f in life["files_before_uninstall"]
                if f.startswith(os.path.join(extensions, ".user", "user_default", "lantern",
                                             "programs"))]
    assert programs and all(f.endswith(".bin") for f in programs)
