"""lantern compare end to end, tiny: 64x36, in both modes, Cycles at 1 and 4 samples
against a 16-sample reference, Lantern at one preset, EEVEE at 1 sample, on a scene
whose image texture is missing. Then the report in headless Chromium.

One comparison runs per module (about 20 s); two more check the reference cache."""
import json
import os
import re
import shutil
import subprocess
import sys

import jsonschema
import numpy as np
import pytest

from lantern.compare import metrics, report

TINY = ["--size", "64x36", "--cycles-samples", "1,4", "--reference-samples", "16",
        "--presets", "low"]
NUMBER = r"[\d.]+(?:e-\d+)?"
ONE_MODE = (rf"Lantern low: {NUMBER} s warm \({NUMBER} s cold\), FLIP {NUMBER}; Cycles [^|]*"
            rf"; EEVEE 1 spp {NUMBER} s, FLIP {NUMBER}")
SUMMARY = re.compile(rf"^direct: {ONE_MODE} \| full: {ONE_MODE}$")
CHROMIUM = "/usr/bin/chromium"


def build_scene(path):
    """A white plane, a cube whose base colour is an image file that does not exist,
    a point light and a camera."""
    import bpy
    from mathutils import Vector
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    white = bpy.data.materials.new("White")
    white.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1)
    bpy.ops.mesh.primitive_plane_add(size=10.0)
    bpy.context.object.data.materials.append(white)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    textured = bpy.data.materials.new("Textured")
    nodes = textured.node_tree.nodes
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = bpy.data.images.new("missing", 4, 4)
    texture.image.source, texture.image.filepath = "FILE", "//textures/missing.png"
    textured.node_tree.links.new(texture.outputs["Color"],
                                 nodes["Principled BSDF"].inputs["Base Color"])
    bpy.context.object.data.materials.append(textured)
    light = bpy.data.objects.new("Light", bpy.data.lights.new("Light", "POINT"))
    light.data.energy = 500.0
    light.location = (2.0, -2.0, 3.0)
    scene.collection.objects.link(light)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (4.0, -5.0, 3.5)
    camera.rotation_euler = (Vector((0, 0, 0.4)) - camera.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = bpy.data.worlds.new("Grey")
    scene.world.color = (0.05, 0.05, 0.05)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


def lantern_compare(*args):
    return subprocess.run([sys.executable, "-m", "lantern", "compare", *map(str, args)],
                          capture_output=True, text=True)


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    folder = tmp_path_factory.mktemp("compare")
    scene = folder / "scene.blend"
    build_scene(scene)
    out, cache = folder / "report", folder / "cache"
    proc = lantern_compare(scene, "-o", out, *TINY, "--eevee", "--eevee-samples", "1",
                           "--cache", cache, "--mode", "direct,full")
    assert proc.returncode == 0, proc.stderr[-3000:]
    with open(out / "results.json") as f:
        results = json.load(f)
    return {"scene": scene, "out": out, "cache": cache, "proc": proc, "results": results}


def test_the_summary_line(compared):
    lines = compared["proc"].stdout.strip().splitlines()
    assert len(lines) == 1 and SUMMARY.match(lines[0]), lines


def test_results_validate_against_the_schema(compared):
    report.validate(compared["results"])


@pytest.mark.parametrize("breakage", [
    lambda r: r.pop("renders"),
    lambda r: r["renders"][0].update(seconds="fast"),
    lambda r: r["equal_error"][0]["cycles"].update(status="almost"),
    lambda r: r["equal_error"][0].update(winner_warm="everyone"),
    lambda r: r["references"]["direct"].update(cache_key="not a hash"),
    lambda r: r["settings"].update(modes=["sideways"]),
    lambda r: r["renders"][0].pop("image"),
    lambda r: r.update(unexpected=1),
])
def test_a_hand_broken_results_json_fails_the_schema(compared, breakage):
    broken = json.loads(json.dumps(compared["results"]))
    breakage(broken)
    with pytest.raises(jsonschema.ValidationError):
        report.validate(broken)


def test_every_scored_image_is_named_and_the_metrics_can_be_recomputed(compared):
    from lantern.engine import read_exr
    out, results = compared["out"], compared["results"]
    renderers = {r["renderer"] for r in results["renders"]}
    assert renderers == {"lantern", "cycles", "eevee"}
    assert [r["samples"] for r in results["renders"] if r["renderer"] == "cycles"] == [1, 4] * 2
    references = {mode: read_exr(str(out / r["image"])) for mode, r in results["references"].items()}
    assert sorted(references) == ["direct", "full"]
    assert all(reference.shape == (36, 64, 4) for reference in references.values())
    for render in results["renders"]:
        image = read_exr(str(out / render["image"]))
        assert (out / render["png"]).is_file()
        # Lantern and Cycles: each image against its own mode's reference; EEVEE: both.
        own = ["direct", "full"] if render["renderer"] == "eevee" else [render["mode"]]
        assert sorted(render["metrics"]) == own
        for mode in own:
            assert (out / render["metrics"][mode]["heatmap"]).is_file()
            again = metrics.score(image, references[mode])["all"]
            assert again == pytest.approx(render["metrics"][mode]["all"])
    assert all((out / results["plots"][mode]).is_file() for mode in ("direct", "full"))


def test_a_broken_image_link_is_reported_and_the_scene_still_renders(compared):
    results = compared["results"]
    broken = results["broken_links"]
    assert [(b["kind"], b["path"]) for b in broken] == [("image", "//textures/missing.png")]
    assert any("missing.png" in w for w in results["warnings"])
    assert results["failures"] == []
    lantern = next(r for r in results["renders"] if r["renderer"] == "lantern"
                   and r["mode"] == "direct")
    assert lantern["problems"]["nonfinite_pixels"] == 0
    assert 0 < lantern["metrics"]["direct"]["all"]["hdr_flip"] < 1
    assert lantern["cold_seconds"] > lantern["seconds"] > 0
    assert results["mask"]["source"] == "lantern_coverage"
    assert lantern["metrics"]["direct"]["foreground"] is not None
    html = (compared["out"] / "index.html").read_text()
    assert "missing.png" in html and "Broken links" in html


def test_the_reference_is_cached_and_a_changed_setting_misses(compared, tmp_path):
    first = compared["results"]["references"]["full"]     # the mode a plain compare runs
    assert first["cached"] is False
    keys = [r["cache_key"] for r in compared["results"]["references"].values()]
    assert sorted(os.listdir(compared["cache"])) == sorted(k + e for k in keys for e in (".exr", ".json"))
    # Same reference settings, a different sweep: the reference comes from the cache.
    def rerun(out, reference_samples):
        proc = lantern_compare(compared["scene"], "-o", out, "--size", "64x36",
                               "--cycles-samples", "1", "--reference-samples", reference_samples,
                               "--presets", "low", "--cache", compared["cache"], "--jobs", "2")
        assert proc.returncode == 0, proc.stderr[-3000:]

    again = tmp_path / "again"
    rerun(again, 16)
    second = json.loads((again / "results.json").read_text())["references"]
    assert list(second) == ["full"]
    second = second["full"]
    assert second["cached"] is True and second["cache_key"] == first["cache_key"]
    assert not (again / "logs" / "reference_full.log").exists()   # nothing rendered it
    assert (again / second["image"]).read_bytes() == \
        (compared["out"] / first["image"]).read_bytes()
    # A different reference (8 samples): a new key, rendered, stored beside the first.
    changed = tmp_path / "changed"
    rerun(changed, 8)
    third = json.loads((changed / "results.json").read_text())["references"]["full"]
    assert third["cached"] is False and third["cache_key"] != first["cache_key"]
    assert third["inputs"]["samples"] == 8
    assert len(os.listdir(compared["cache"])) == 6


def test_a_failed_job_is_one_line_and_the_others_go_on(tmp_path):
    from lantern.compare.tasks import Job, run_job
    job = run_job(Job("lantern low", {"job": "lantern", "scene": str(tmp_path / "gone.blend"),
                                      "frame": 1.0, "size": [8, 8], "preset": "low",
                                      "transparent": False, "warm_runs": 1,
                                      "image": str(tmp_path / "x.exr")}, 1),
                  str(tmp_path / "logs"), lambda *_: None)
    assert job.result is None
    assert "gone.blend" in job.error and "\n" not in job.error


@pytest.mark.parametrize("args, status, message", [
    (["scene.usd", "-o", "out"], 2, "needs a .blend"),
    (["{scene}", "-o", "out", "--presets", "low,best"], 2, "--presets best"),
    (["{scene}", "-o", "out", "--mode", "sideways"], 2, "choose from direct, full"),
    (["{scene}", "-o", "out", "--cycles-samples", "0,4"], 2, "positive"),
    (["{folder}/gone.blend", "-o", "out"], 1, "no such file"),
])
def test_wrong_command_lines(compared, tmp_path, args, status, message):
    args = [a.format(scene=compared["scene"], folder=tmp_path) for a in args]
    proc = lantern_compare(*args)
    assert proc.returncode == status
    assert message in proc.stderr.strip().splitlines()[-1]


# --- the report in a browser ----------------------------------------------------------

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--no-first-run"]


def open_in_chromium(index, screenshot, profile):
    """Opens index.html in Debian's chromium (headless, a fresh profile): (images as
    [src, naturalWidth], console errors). Saves a full-page screenshot."""
    from playwright.sync_api import sync_playwright
    errors = []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch_persistent_context(
            str(profile), executable_path=CHROMIUM, headless=True, args=FLAGS,
            viewport={"width": 1400, "height": 900})
        try:
            page = browser.new_page()
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(index.as_uri(), wait_until="load")
            images = page.evaluate(
                "Array.from(document.images).map(i => [i.getAttribute('src'), i.naturalWidth])")
            page.screenshot(path=str(screenshot), full_page=True)
        finally:
            browser.close()
    return images, errors


@pytest.fixture(scope="module")
def chromium():
    if not os.access(CHROMIUM, os.X_OK):
        pytest.fail(f"{CHROMIUM} is missing: `make setup` installs Debian's chromium")
    return CHROMIUM


def test_the_report_opens_in_chromium_with_every_image(compared, chromium, tmp_path):
    screenshot = tmp_path / "report.png"
    images, errors = open_in_chromium(compared["out"] / "index.html", screenshot,
                                      tmp_path / "profile")
    assert errors == []
    sources = [src for src, _ in images]
    assert compared["results"]["plots"]["direct"] in sources
    expected = {r["png"] for r in compared["results"]["renders"]}
    expected |= {m["heatmap"] for r in compared["results"]["renders"] for m in r["metrics"].values()}
    assert expected <= set(sources)
    assert all(width > 0 for _, width in images), images
    assert screenshot.stat().st_size > 10_000


def test_the_browser_check_sees_a_missing_image(compared, chromium, tmp_path):
    broken = tmp_path / "broken"
    shutil.copytree(compared["out"], broken)
    (broken / compared["results"]["plots"]["direct"]).unlink()
    images, errors = open_in_chromium(broken / "index.html", tmp_path / "shot.png",
                                      tmp_path / "profile")
    assert dict(images)[compared["results"]["plots"]["direct"]] == 0
    assert errors, "a missing image must show as a console error"


@pytest.mark.parametrize("pixel_filter, antialias", [(0.01, False), (1.5, True)])
def test_a_point_sampled_comparison_renders_lantern_without_anti_aliasing(tmp_path, pixel_filter,
                                                                         antialias):
    """Cycles with a filter narrower than half a pixel shades pixel centres: Lantern is
    compared with its supersampling and FXAA off, as tests/test_shadows_vs_cycles.py
    compares it; with a real filter, Lantern keeps its preset's anti-aliasing."""
    from lantern.compare import cache, run
    scene = tmp_path / "scene.blend"
    scene.write_bytes(b"BLENDER")
    options = run.Options(scene=str(scene), out=str(tmp_path / "out"), presets=("medium", "high"),
                          pixel_filter=pixel_filter, cache=str(tmp_path / "cache"))
    scan = {"scene": {"blender": "5.0.1", "film_transparent": False}, "links": []}
    files = cache.scene_inputs(str(scene), [])
    jobs, _ = run._plan(options, str(tmp_path / "out"), scan, files, (16, 9), 1.0)
    lantern = [job for job in jobs if job.spec["job"] == "lantern"]
    assert [job.spec["antialias"] for job in lantern] == [antialias, antialias]


def test_each_mode_has_lantern_images_lit_as_its_reference(tmp_path):
    """Full mode by default; with direct,full, one Lantern job per mode and preset, lit
    directly (bounces 0) for direct and with the scene's bounces for full."""
    from lantern.compare import cache, command, run
    scene = tmp_path / "scene.blend"
    scene.write_bytes(b"BLENDER")
    assert run.Options(scene=str(scene), out="out").modes == ("full",)
    assert command.DEFAULTS.modes == ("full",)
    options = run.Options(scene=str(scene), out=str(tmp_path / "out"), presets=("low", "high"),
                          modes=("direct", "full"), cache=str(tmp_path / "cache"))
    scan = {"scene": {"blender": "5.0.1", "film_transparent": False}, "links": []}
    jobs, _ = run._plan(options, str(tmp_path / "out"), scan,
                        cache.scene_inputs(str(scene), []), (16, 9), 1.0)
    lantern = [(j.extra["mode"], j.extra["preset"], j.spec["direct"], os.path.basename(j.spec["image"]))
               for j in jobs if j.spec["job"] == "lantern"]
    assert lantern == [("direct", "low", True, "lantern_low_direct.exr"),
                       ("direct", "high", True, "lantern_high_direct.exr"),
                       ("full", "low", False, "lantern_low_full.exr"),
                       ("full", "high", False, "lantern_high_full.exr")]
