"""The comparison suite (`make compare`): `lantern compare` on every scene below, in
both modes (direct: bounces 0; full: the scene's bounces), one report per scene, and
out/compare/index.html (with summary.json and summary.md) linking them, a table per
mode that names the scenes where Lantern is fastest at equal error. Not part of
`make test`; it prints figures and asserts nothing.

Scenes, built or copied into a temporary folder by a Blender process (`--build`):
- calibration, at the sizes and with the references the pipeline tests use, so that
  their bounds apply here too: one light of each type over a white plane
  (tests/calibration.build_scene, 48x48, 4096 spp) and a box on the plane per light
  type, shadows on (calibration.build_box_scene, 96x54, 2048 spp); both point-sampled
  (pixel filter 0.01) like their references in tests/references;
- glossy spheres, metallic, roughness 0.1 to 1, under an area light; a plane with a
  normal map (the corpus's 08_normal_ribs.png, read in place);
- every .blend of ../shared/corpus/blender, copied with its relative links remapped
  to the corpus (nothing copied), and its broken links repaired in the copy as
  reference_scenes.py repairs them in memory: each repair is listed in the scene's
  report and in the summary;
- the 16-character rigged crowd of bench_skel_export.py, lit, at frame 25.
- from tests/reference_scenes.py: the environment-lit spheres (diffuse and
  mirror), the AO corner under a uniform world and the grazing MIP checker, at their
  own sizes and samples;

    .venv/bin/python bench/compare_suite.py [--out out/compare] [--only NAME ...]
        [--mode direct,full] [--presets low,medium,...] [--cycles-samples 1,4,...]

(--only measures those scenes again and keeps the other rows of an earlier summary.)
"""
import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parent
TESTS = REPO / "tests"
CORPUS = REPO.parent / "shared" / "corpus" / "blender"
NORMAL_MAP = CORPUS / "08_normal_ribs.png"

SIZE = (160, 90)               # every scene without a size of its own
SWEEP = (1, 4, 16, 64, 256)
REFERENCE_SAMPLES = 1024       # 4x the sweep's last point; calibration scenes use their tests'
MODES = ("direct", "full")     # every scene in both (lantern.compare.modes)
EEVEE_SAMPLES = (1, 4, 16)     # 64 would double the suite's time on 2 cores
CROWD_FRAME = 25
POINT_SAMPLED = 0.01           # pixel filter width of the calibration references
# Calibration scenes of the shading work (tests/reference_scenes.py builds them, at their own
# size and samples, for its committed Cycles references): the environment-lit spheres
# (diffuse and mirror), the AO corner, the grazing MIP checker.
LOOKS_SCENES = ("environment_diffuse", "environment_mirror", "ao_corner", "tex_grazing_checker")
# What "keep the bounds set by the pipeline issues" means for each calibration kind:
# the preset and the test that set the bound.
PLANE_BOUND = {"preset": "medium", "metric": "mean relative error, lit area",
               "bound": 0.005 + 0.001,
               "source": "tests/test_light_calibration.py: 0.5% against the closed form, "
                         "plus the 0.1% by which Cycles itself may differ from it"}


def _box_bounds():
    sys.path.insert(0, str(TESTS))
    from test_shadows_vs_cycles import THRESHOLDS
    return THRESHOLDS


# --- building the scenes (in a Blender process) ----------------------------------------

def _principled(name, color, roughness, metallic=0.0):
    import bpy
    material = bpy.data.materials.new(name)
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    return material


def _camera(scene, location, target, lens=50.0):
    import bpy
    from mathutils import Vector
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.lens = lens
    camera.location = location
    camera.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera


def _world(scene, strength):
    import bpy
    world = bpy.data.worlds.new("Uniform")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = strength
    scene.world = world


def _empty(size=SIZE):
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = size
    return scene


def build_glossy_spheres():
    import bpy
    import calibration
    scene = _empty()
    bpy.ops.mesh.primitive_plane_add(size=30.0)
    bpy.context.object.data.materials.append(_principled("Ground", (0.5, 0.5, 0.5), 1.0))
    for i, roughness in enumerate((0.1, 0.325, 0.55, 0.775, 1.0)):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.8,
                                             location=(-4.0 + 2.0 * i, 0.0, 0.8))
        bpy.ops.object.shade_smooth()
        bpy.context.object.data.materials.append(
            _principled(f"Metal{roughness}", (0.95, 0.64, 0.54), roughness, metallic=1.0))
    calibration.add_light(scene, "Area", dict(type="AREA", energy=800.0, location=(0.0, -4.0, 5.0),
                                              size=2.0, target=(0.0, 0.0, 0.8)), shadow=True)
    _world(scene, 0.1)
    _camera(scene, (0.0, -10.0, 3.5), (0.0, 0.0, 0.6), lens=35.0)
    return scene


def build_normal_mapped_plane():
    import bpy
    import calibration
    scene = _empty()
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    material = _principled("Ribs", (0.8, 0.8, 0.8), 0.5)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = bpy.data.images.load(str(NORMAL_MAP))   # absolute: read in place
    texture.image.colorspace_settings.name = "Non-Color"
    normal_map = nodes.new("ShaderNodeNormalMap")
    links.new(texture.outputs["Color"], normal_map.inputs["Color"])
    links.new(normal_map.outputs["Normal"], nodes["Principled BSDF"].inputs["Normal"])
    bpy.context.object.data.materials.append(material)
    calibration.add_light(scene, "Sun", dict(type="SUN", energy=3.0, location=(0, 0, 5),
                                             rotation=(math.radians(70), 0, math.radians(30))),
                          shadow=False)
    _world(scene, 0.05)
    _camera(scene, (0.0, -4.5, 3.5), (0.0, 0.0, 0.0))
    return scene


def build_crowd():
    import bpy
    sys.path.insert(0, str(HERE))
    import bench_skel_export
    import calibration
    scene = _empty()
    scene.frame_start, scene.frame_end = 1, bench_skel_export.FRAMES
    for i in range(16):
        bench_skel_export._character(i)
    skin = _principled("Skin", (0.8, 0.55, 0.4), 0.6)
    for obj in scene.objects:
        if obj.type == "MESH":
            obj.data.materials.append(skin)
            for polygon in obj.data.polygons:
                polygon.use_smooth = True
    bpy.ops.mesh.primitive_plane_add(size=80.0, location=(15.0, 0.0, 0.0))
    bpy.context.object.data.materials.append(_principled("Ground", (0.5, 0.5, 0.5), 1.0))
    calibration.add_light(scene, "Sun", dict(type="SUN", energy=3.0, location=(0, 0, 10),
                                             rotation=(math.radians(40), 0, math.radians(-30)),
                                             angle=math.radians(3)), shadow=True)
    _world(scene, 0.1)
    _camera(scene, (15.0, -26.0, 9.0), (15.0, 0.0, 1.2), lens=36.0)
    scene.frame_set(CROWD_FRAME)
    return scene


def repair_copy(source, target, workdir):
    """Opens a corpus .blend, repairs its broken links as tests/reference_scenes.py does
    for the Cycles references (tests/references/; one repair, shared), saves the copy; returns
    the repairs made (strings)."""
    import bpy
    import reference_scenes
    bpy.ops.wm.open_mainfile(filepath=str(source), load_ui=False)
    repairs = []
    for world in bpy.data.worlds:
        for node in (world.node_tree.nodes if world.node_tree else ()):
            image = getattr(node, "image", None)
            if node.bl_idname != "ShaderNodeTexEnvironment" or image is None \
                    or image.packed_file is not None \
                    or os.path.isfile(bpy.path.abspath(image.filepath, library=image.library)):
                continue
            node.image = bpy.data.images.load(reference_scenes.write_sky(workdir))
            repairs.append(f"world '{world.name}': environment image {image.filepath} is not in "
                           "the corpus; shows reference_scenes.py's asymmetric lat-long sky "
                           "(the one tests/references/ uses) instead")
    for material in bpy.data.materials:
        groups = [n for n in (material.node_tree.nodes if material.node_tree else ())
                  if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None
                  and n.node_tree.is_missing and n.node_tree.name == "glTF Metallic Roughness"]
        if groups:
            reference_scenes._principled_for_gltf_group(material)
            repairs.append(f"material '{material.name}': the node group 'glTF Metallic "
                           "Roughness' (library //../pbr_node/glTF2.blend, not in the corpus) "
                           "replaced by the Principled BSDF network Blender's glTF importer "
                           "makes (reference_scenes._principled_for_gltf_group)")
    for light in bpy.data.lights:
        tree = light.node_tree if light.use_nodes else None
        if tree and any(n.bl_idname == "ShaderNodeGroup" and n.node_tree and n.node_tree.is_missing
                        for n in tree.nodes):
            light.use_nodes = False
            repairs.append(f"light '{light.name}': its nodes use a glTF light group whose "
                           "library is not in the corpus; nodes turned off, so the light "
                           f"emits its own {light.energy:g} W, as Lantern reads it")
    for library in list(bpy.data.libraries):
        if os.path.isfile(bpy.path.abspath(library.filepath)):
            continue
        users = [i.name for i in (*bpy.data.node_groups, *bpy.data.materials)
                 if i.library == library and i.users > 0]
        if users:
            continue  # still used: left missing, and reported by compare
        written = library.filepath
        bpy.data.libraries.remove(library)
        repairs.append(f"library {written}: not in the corpus and no longer used by "
                       "anything; removed from the copy")
    bpy.ops.wm.save_as_mainfile(filepath=str(target), copy=True, relative_remap=True)
    return repairs


def build(folder, only):
    """Writes every scene's .blend into `folder`, and manifest.json describing them."""
    import bpy
    sys.path.insert(0, str(TESTS))
    import calibration
    folder = pathlib.Path(folder)
    scenes = {}

    def save(name, group, **extra):
        path = folder / f"{name}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(path))
        scenes[name] = {"blend": str(path), "group": group, "repairs": [], **extra}

    wanted = (lambda name: not only or name in only)
    for kind in calibration.LIGHTS:
        if wanted(f"plane_{kind}"):
            calibration.build_scene(kind)
            save(f"plane_{kind}", "calibration", size=[calibration.SIZE] * 2,
                 reference_samples=4096, pixel_filter=POINT_SAMPLED, bound=dict(PLANE_BOUND))
    for kind in calibration.BOX_LIGHTS:
        if wanted(f"box_{kind}"):
            calibration.build_box_scene(kind)
            save(f"box_{kind}", "calibration", size=list(calibration.BOX_SIZE),
                 reference_samples=2048, pixel_filter=POINT_SAMPLED,
                 bound={"preset": "medium", "metric": "HDR-FLIP",
                        "bound": _box_bounds()[kind],
                        "source": "tests/test_shadows_vs_cycles.py THRESHOLDS"})
    for name, builder in (("glossy_spheres", build_glossy_spheres),
                          ("normal_mapped_plane", build_normal_mapped_plane)):
        if wanted(name):
            builder()
            save(name, "calibration")
    import reference_scenes
    for name in LOOKS_SCENES:
        if wanted(name):
            reference_scenes.build(name, folder / "looks")
            spec = reference_scenes.SCENES[name]
            save(name, "calibration", size=list(spec.size), reference_samples=spec.samples)
    if wanted("crowd_16"):
        build_crowd()
        save("crowd_16", "crowd", frame=CROWD_FRAME)
    for source in sorted(CORPUS.glob("*.blend")):
        name = source.stem
        if not wanted(name):
            continue
        corpus = folder / "corpus"
        corpus.mkdir(exist_ok=True)
        target = corpus / source.name
        scenes[name] = {"blend": str(target), "group": "corpus",
                        "source": os.path.relpath(source, REPO),
                        "repairs": repair_copy(source, target, str(corpus))}
    with open(folder / "manifest.json", "w") as f:
        json.dump(scenes, f, indent=2)


# --- running the comparisons ------------------------------------------------------------

def _relative_error_in_lit_area(report_dir, results, preset):
    """Lantern's mean |L/C - 1| where the reference exceeds 5% of its maximum (the
    calibration test's lit area), recomputed from the EXRs results.json names."""
    import numpy as np

    from lantern.engine.image_io import read_exr
    reference = read_exr(str(report_dir / results["references"]["direct"]["image"]))[..., :3]
    render = next(r for r in results["renders"] if r["renderer"] == "lantern"
                  and r["preset"] == preset and r["mode"] == "direct")
    lantern = read_exr(str(report_dir / render["image"]))[..., :3]
    luminance = reference.mean(axis=-1)
    lit = luminance > 0.05 * luminance.max()
    return float(np.abs(lantern[lit] / reference[lit] - 1.0).mean())


def _bound_check(entry, report_dir, results):
    """The calibration bound (set in direct mode by its test), where direct was run."""
    bound = entry.get("bound")
    if not bound or "direct" not in results["references"]:
        return None
    if bound["metric"] == "HDR-FLIP":
        row = next((r for r in results["equal_error"] if r["preset"] == bound["preset"]
                    and r["mode"] == "direct"), None)
        value = row["flip"] if row else None
    else:
        value = _relative_error_in_lit_area(report_dir, results, bound["preset"])
    return bound | {"value": value, "holds": value is not None and value <= bound["bound"]}


def run_scene(name, entry, args):
    from lantern.compare.run import CompareError, Options, compare
    out = pathlib.Path(args.out) / name
    options = Options(
        scene=entry["blend"], out=str(out), frame=entry.get("frame"),
        size=tuple(entry.get("size") or args.size), cycles_samples=args.cycles_samples,
        presets=args.presets, modes=args.mode,
        reference_samples=entry.get("reference_samples", args.reference_samples),
        eevee=not args.no_eevee, eevee_samples=EEVEE_SAMPLES, jobs=args.jobs,
        pixel_filter=entry.get("pixel_filter", 1.5), cache=args.cache,
        extra_notes=[f"suite repair: {r}" for r in entry["repairs"]])
    start = time.perf_counter()
    try:
        results = compare(options)
    except CompareError as error:
        return {"name": name, "error": str(error)}
    return {"name": name, "group": entry["group"], "source": entry.get("source"),
            "repairs": entry["repairs"], "report": f"{name}/index.html",
            "summary": results["summary"], "equal_error": results["equal_error"],
            "failures": results["failures"], "broken_links": results["broken_links"],
            "warnings": len(results["warnings"]), "size": results["scene"]["size"],
            "pixel_filter": options.pixel_filter, "bound": _bound_check(entry, out, results),
            "eevee": _eevee_points(results), "seconds": time.perf_counter() - start}


def _eevee_points(results):
    """Per mode, EEVEE's (samples, seconds, HDR-FLIP against that mode's reference)."""
    from lantern.compare.curves import hdr_flip
    return {mode: [{"samples": r["samples"], "seconds": r["seconds"], "flip": hdr_flip(r, mode)}
                   for r in results["renders"] if r["renderer"] == "eevee"]
            for mode in results["settings"]["modes"]}


# --- the summary -----------------------------------------------------------------------

def _equal(entry):
    if entry is None:
        return "–"
    if entry["status"] == "reached":
        return f"{entry['seconds']:.3g} s ({entry['ratio_warm']:.3g}×)"
    if entry["status"] == "already_below":
        return f"≤ {entry['bound_seconds']:.3g} s (below at {entry['bound_samples']} spp)"
    return f"> {entry['bound_seconds']:.3g} s (not by {entry['bound_samples']} spp)"


def _eevee_cell(scene, row):
    points = scene["eevee"].get(row["mode"], [])
    first = min(points, key=lambda p: p["samples"]) if points else None
    text = f"1 spp {first['seconds']:.2g} s, FLIP {first['flip']:.3f}" if first and first["flip"] is not None else "–"
    if row.get("eevee"):
        text += f"; at equal FLIP {_equal(row['eevee'])}"
    return text


def _winner(row):
    if row["winner_warm"] == "lantern" and row["better_at_cheapest"]:
        return "lantern, at a higher error than " + " and ".join(
            f"{n.replace('_', ' ')}'s cheapest" for n in row["better_at_cheapest"])
    return row["winner_warm"]


def summary_rows(scenes, mode, preset=None):
    rows = []
    for scene in scenes:
        for row in scene.get("equal_error", []):
            if row["mode"] != mode or (preset and row["preset"] != preset):
                continue
            bound = scene.get("bound") if mode == "direct" else None
            check = "" if not bound or bound["preset"] != row["preset"] else (
                f"{'holds' if bound['holds'] else 'FAILS'} ({bound['value']:.4f} ≤ {bound['bound']})")
            rows.append([scene["name"], row["preset"], f"{row['lantern_warm_seconds'] * 1000:.1f} ms",
                         f"{row['lantern_cold_seconds']:.2f} s", f"{row['flip']:.4f}",
                         _equal(row["cycles"]), _eevee_cell(scene, row), _winner(row), check])
    return rows


HEADER = ["scene", "preset", "Lantern warm", "Lantern cold", "HDR-FLIP",
          "Cycles at equal FLIP (× Lantern warm)", "EEVEE", "fastest at equal FLIP (warm)",
          "calibration bound"]


def fastest(scenes, mode):
    """The scenes where a Lantern preset is fastest at its own error in `mode` (warm),
    each with those presets: {scene: [preset, ...]}. A win where another renderer's
    cheapest image is already more accurate is not counted (its row says so)."""
    won = {}
    for scene in scenes:
        for row in scene.get("equal_error", []):
            if row["mode"] == mode and row["winner_warm"] == "lantern" \
                    and not row["better_at_cheapest"]:
                won.setdefault(scene["name"], []).append(row["preset"])
    return won


def _fastest_line(scenes, mode):
    won = fastest(scenes, mode)
    names = ", ".join(f"{name} ({', '.join(presets)})" for name, presets in won.items())
    return (f"Lantern fastest at equal error in {mode} mode (warm): "
            f"{len(won)} of {len(scenes)} scenes" + (f": {names}" if names else ""))


def _modes(scenes):
    """The modes the scenes were measured in, in the suite's order."""
    seen = {row["mode"] for scene in scenes for row in scene.get("equal_error", [])}
    return [mode for mode in MODES if mode in seen]


def markdown(scenes, preset=None):
    lines = []
    for mode in _modes(scenes):
        lines += [f"## {mode} mode", "", _fastest_line(scenes, mode), "",
                  "| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
        lines += ["| " + " | ".join(cells) + " |" for cells in summary_rows(scenes, mode, preset)]
        lines.append("")
    return "\n".join(lines)


def write_summary(out, scenes, args, seconds):
    import html

    from lantern.compare.files import write_json, write_text
    modes = _modes(scenes)
    write_json(str(out / "summary.json"), {
        "scenes": scenes, "seconds": seconds, "settings": vars(args),
        "lantern_fastest": {mode: fastest(scenes, mode) for mode in modes}})
    write_text(str(out / "summary.md"), markdown(scenes))
    e = html.escape
    body = ["<!doctype html><html lang=en><head><meta charset=utf-8><link rel=icon href=\"data:,\">"
            "<title>lantern compare: suite</title><style>body{font:14px/1.4 system-ui,sans-serif;"
            "margin:1.5em}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
            "padding:2px 6px}th{background:#f3f3f3}.bad{color:#b00}</style></head><body>",
            f"<h1>lantern compare: the suite</h1><p>{len(scenes)} scenes in {seconds / 60:.1f} min; "
            "times and the winner are per image, Lantern warm (see each report for what every "
            "time includes).</p>"]
    for mode in modes:
        body.append(f"<h2>{e(mode)} mode</h2><p>{e(_fastest_line(scenes, mode))}</p><table><tr>" +
                    "".join(f"<th>{e(h)}</th>" for h in HEADER) + "</tr>")
        for scene in scenes:
            if "error" in scene:
                body.append(f"<tr><td>{e(scene['name'])}</td><td colspan={len(HEADER) - 1} "
                            f"class=bad>{e(scene['error'])}</td></tr>")
                continue
            for cells in summary_rows([scene], mode):
                cells[0] = f"<a href=\"{e(scene['report'])}\">{e(cells[0])}</a>"
                body.append("<tr>" + "".join(f"<td>{c if i == 0 else e(c)}</td>"
                                             for i, c in enumerate(cells)) + "</tr>")
        body.append("</table>")
    body.append("<h2>Repairs made in the copies of corpus scenes</h2><ul>")
    for scene in scenes:
        for repair in scene.get("repairs", []):
            body.append(f"<li>{e(scene['name'])}: {e(repair)}</li>")
    body.append("</ul><h2>Broken links left (reported by each scene's compare)</h2><ul>")
    for scene in scenes:
        for link in scene.get("broken_links", []):
            body.append(f"<li>{e(scene['name'])}: {e(link['kind'])} {e(link['path'])}</li>")
    body.append("</ul></body></html>\n")
    write_text(str(out / "index.html"), "\n".join(body))


def _with_earlier(out, scenes, only):
    """With --only, the scenes just run replace theirs in the summary an earlier run left
    in `out`, and the others are kept, so one scene can be measured again."""
    earlier = out / "summary.json"
    if not only or not earlier.is_file():
        return scenes
    fresh = {scene["name"]: scene for scene in scenes}
    kept = json.loads(earlier.read_text())["scenes"]
    merged = [fresh.pop(scene["name"], scene) for scene in kept]
    return merged + list(fresh.values())


def _names(text):
    return tuple(part.strip() for part in text.split(",") if part.strip())


def _mode_names(text):
    wrong = [mode for mode in _names(text) if mode not in MODES]
    if wrong:
        raise argparse.ArgumentTypeError(f"{', '.join(wrong)}: choose from {', '.join(MODES)}")
    return _names(text)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "out" / "compare"))
    parser.add_argument("--only", nargs="*", default=None, metavar="NAME",
                        help="only these scenes (plane_sun, box_point, glossy_spheres, "
                             "crowd_16, 02_suzanne, ...); they replace their rows in the "
                             "summary an earlier run left in --out")
    parser.add_argument("--size", default=SIZE, type=lambda t: tuple(map(int, t.split("x"))),
                        help=f"image size of scenes without their own (default {SIZE[0]}x{SIZE[1]})")
    parser.add_argument("--reference-samples", type=int, default=REFERENCE_SAMPLES)
    parser.add_argument("--mode", type=_mode_names, default=MODES,
                        help="reference modes, comma-separated (default direct,full)")
    parser.add_argument("--presets", type=_names, default=None,
                        help="Lantern presets, comma-separated (default: all)")
    parser.add_argument("--cycles-samples", type=lambda t: tuple(map(int, _names(t))),
                        default=SWEEP, help="the Cycles sweep (default 1,4,16,64,256)")
    parser.add_argument("--no-eevee", action="store_true")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--cache", default=None)
    parser.add_argument("--build", default=None, help=argparse.SUPPRESS)  # the Blender half
    args = parser.parse_args()
    if args.build:
        import lantern.exporters  # noqa: F401  (Blender's pxr first)
        build(args.build, set(args.only or ()))
        return 0
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="lantern-compare-suite-") as folder:
        command = [sys.executable, __file__, "--build", folder] + (
            ["--only", *args.only] if args.only else [])
        built = subprocess.run(command, capture_output=True, text=True)
        if built.returncode != 0:
            print(built.stderr[-3000:], file=sys.stderr)
            print("compare_suite: building the scenes failed", file=sys.stderr)
            return 1
        manifest = json.loads((pathlib.Path(folder) / "manifest.json").read_text())
        scenes = []
        for index, (name, entry) in enumerate(manifest.items(), 1):
            print(f"[{index}/{len(manifest)}] {name}", file=sys.stderr, flush=True)
            scenes.append(run_scene(name, entry, args))
            print(f"{name}: {scenes[-1].get('summary') or scenes[-1].get('error')}", flush=True)
    seconds = time.perf_counter() - start
    scenes = _with_earlier(out, scenes, args.only)
    if args.only:   # the time of every scene's compare, earlier runs' included
        seconds = sum(scene.get("seconds", 0.0) for scene in scenes)
    write_summary(out, scenes, args, seconds)
    print()
    print(markdown(scenes, preset="medium"))
    print(f"{len(scenes)} scenes in {seconds / 60:.1f} min; report: {out / 'index.html'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
