"""`lantern compare`: one scene, every renderer, error against time, one report.

The steps, each in its own module:
1. scan the .blend (a worker): frame, size, camera, film, linked files;
2. render (tasks.py runs worker.py jobs): the Cycles reference per mode (cache.py),
   the Cycles sweep, optionally Cycles denoised and EEVEE, Lantern per preset;
3. score every image against each mode's reference (metrics.py) and read the
   equal-error times off the curves (curves.py);
4. write DIR/results.json, DIR/index.html and their images (report.py).
The parent never imports bpy: every render runs in a worker process."""
from __future__ import annotations

import dataclasses
import datetime
import os
import platform
import shutil
from dataclasses import dataclass, field

from ..core.version import installed_version
from . import cache as reference_cache
from .curves import EqualError, hdr_flip, sweep_points, time_to_reach
from .files import atomic_write
from .lantern_timing import point_sampled
from .tasks import Job, run_job, run_jobs

DEFAULT_WIDTH = 320        # without --size: this wide, at the scene's aspect
SWEEP_SEED = 0             # Blender's default seed
REFERENCE_SEED = 7919      # any other: the reference's noise is independent of the sweep's
MASK_THRESHOLD = 0.5       # coverage or alpha above this is foreground
RENDERERS = ("cycles", "cycles_denoised", "eevee")


def preset_names():
    """The engine's quality presets, in their table's order."""
    from ..core.presets import PRESETS
    return tuple(PRESETS)


class CompareError(Exception):
    """The comparison cannot be made at all (the scene cannot be read)."""


@dataclass
class Options:
    scene: str
    out: str
    frame: float | None = None
    size: tuple | None = None
    presets: tuple | None = None   # None: every preset of the engine's table
    cycles_samples: tuple = (1, 4, 16, 64, 256)
    reference_samples: int = 4096
    eevee: bool = False
    eevee_samples: tuple = (1, 4, 16, 64)
    modes: tuple = ("full",)
    cycles_denoised: bool = False
    jobs: int = 1
    cache: str | None = None
    pixel_filter: float = 1.5
    warm_runs: int = 5
    quiet: bool = False        # no progress bar
    extra_notes: list = field(default_factory=list)  # e.g. the suite's repairs


def _rel(out, path):
    return os.path.relpath(path, out) if path else None


def _scan(options, log_dir):
    job = run_job(Job("scan", {"job": "scan", "scene": os.path.abspath(options.scene)}, 0),
                  log_dir, lambda *_: None)
    if job.error is not None:
        raise CompareError(f"{options.scene}: cannot be read: {job.error}")
    return job.result


def _size(options, scene):
    if options.size:
        return tuple(int(v) for v in options.size)
    width, height = scene["resolution"]
    return DEFAULT_WIDTH, max(1, round(DEFAULT_WIDTH * height / width))


def _image(out, stem):
    return os.path.join(out, "images", stem + ".exr")


def _plan(options, out, scan, scene_files, size, frame):
    """(jobs, references): the worker jobs to run, and per mode the reference entry
    (cached, or the job that renders it). scene_files: cache.scene_inputs."""
    scene_path = os.path.abspath(options.scene)
    common = {"scene": scene_path, "frame": frame, "size": list(size)}
    cache = reference_cache.ReferenceCache(options.cache or reference_cache.default_dir())
    references, jobs = {}, []
    for mode in options.modes:
        settings = {"size": list(size), "frame": frame, "samples": options.reference_samples,
                    "seed": REFERENCE_SEED, "mode": mode, "filter_width": options.pixel_filter,
                    "blender": scan["scene"]["blender"]}
        inputs = reference_cache.reference_inputs(scene_files, settings)
        key = reference_cache.key_of(inputs)
        path = _image(out, f"reference_{mode}")
        hit = cache.lookup(key)
        reference = {"mode": mode, "image": path, "samples": options.reference_samples,
                     "seed": REFERENCE_SEED, "cache_key": key, "inputs": inputs,
                     "cached": hit is not None, "seconds": hit.get("seconds") if hit else None,
                     "cache": cache}
        if hit:
            atomic_write(path, lambda tmp, src=hit["image"]: shutil.copyfile(src, tmp), ".exr")
        else:
            reference["job"] = Job(f"reference {mode}", common | {
                "job": "cycles", "engine": "cycles", "samples": [options.reference_samples],
                "images": [path], "seed": REFERENCE_SEED, "mode": mode, "denoise": False,
                "filter_width": options.pixel_filter, "warm_up": False, "repeat": False}, 1)
            jobs.append(reference["job"])
        references[mode] = reference
    for mode in options.modes:
        for denoise in (False, True) if options.cycles_denoised else (False,):
            label = "cycles_denoised" if denoise else "cycles"
            jobs.append(Job(f"{label} {mode}", common | {
                "job": "cycles", "engine": "cycles", "samples": list(options.cycles_samples),
                "images": [_image(out, f"{label}_{mode}_{s:04d}spp") for s in options.cycles_samples],
                "seed": SWEEP_SEED, "mode": mode, "denoise": denoise,
                "filter_width": options.pixel_filter}, len(options.cycles_samples),
                extra={"renderer": label, "mode": mode, "denoised": denoise}))
    if options.eevee:
        jobs.append(Job("eevee", common | {
            "job": "eevee", "engine": "eevee", "samples": list(options.eevee_samples),
            "images": [_image(out, f"eevee_{s:04d}spp") for s in options.eevee_samples]},
            len(options.eevee_samples), extra={"renderer": "eevee"}))
    transparent = scan["scene"]["film_transparent"]
    for mode in options.modes:
        for preset in options.presets:
            first = (mode, preset) == (options.modes[0], options.presets[0])
            coverage = _image(out, "lantern_coverage") if first and not transparent else None
            jobs.append(Job(f"lantern {preset} {mode}", common | {
                "job": "lantern", "preset": preset, "transparent": transparent,
                "antialias": not point_sampled(options.pixel_filter),
                "warm_runs": options.warm_runs, "image": _image(out, f"lantern_{preset}_{mode}"),
                # Lit as its mode's reference is: bounces 0, or the scene's.
                "direct": mode == "direct",
                "coverage": coverage}, 1,
                extra={"renderer": "lantern", "preset": preset, "mode": mode}))
    return jobs, references


def _store_references(references):
    for reference in references.values():
        job = reference.pop("job", None)
        if job is None or job.result is None:
            continue
        point = job.result["points"][0]
        reference["seconds"] = point["seconds"]
        reference["cache"].store(reference["cache_key"], reference["image"],
                                 {"inputs": reference["inputs"], "seconds": point["seconds"]})


def _mask(loaded, references, lantern_jobs, film_transparent):
    """(mask or None, description) of the foreground. loaded: the reference images
    read, by mode."""
    from ..engine.image_io import read_exr
    if film_transparent and loaded:
        mode, image = next(iter(loaded.items()))
        return image[..., 3] > MASK_THRESHOLD, {"source": "reference_alpha",
                                                "image": references[mode]["image"]}
    for job in lantern_jobs:
        coverage = job.result and job.result.get("coverage")
        if coverage and os.path.isfile(coverage):
            alpha = read_exr(coverage)[..., 3]
            return alpha > MASK_THRESHOLD, {"source": "lantern_coverage", "image": coverage}
    return None, {"source": "none", "image": None}


def _winner(times):
    """times: {renderer: (low, high)} bounds on its equal-error time. The renderer
    whose whole interval lies below every other's lower bound, else "undecided"."""
    for name, (_, high) in times.items():
        if all(high < low for other, (low, _) in times.items() if other != name):
            return name
    return "undecided"


def _bounds(result: EqualError):
    """(low, high) bounds on a renderer's equal-error time. Already below at 1 sample
    is exact: no render is cheaper than one sample, and that one reaches the target."""
    if result.status == "reached":
        return result.seconds, result.seconds
    if result.status == "already_below":
        exact = result.bound_samples == 1
        return (result.bound_seconds if exact else 0.0), result.bound_seconds
    if result.status == "not_reached":
        return result.bound_seconds, float("inf")
    return None


def _equal_error(renders, modes, presets):
    rows = []
    for mode in modes:
        curves = {name: sweep_points(renders, name, mode) for name in RENDERERS}
        for preset in presets:
            lantern = next((r for r in renders if r["renderer"] == "lantern"
                            and r["preset"] == preset and r["mode"] == mode), None)
            target = lantern and hdr_flip(lantern, mode)
            if target is None:
                continue
            row = {"mode": mode, "preset": preset, "flip": target,
                   "lantern_warm_seconds": lantern["seconds"],
                   "lantern_cold_seconds": lantern["cold_seconds"]}
            found = {name: time_to_reach(curves[name], target) for name in RENDERERS
                     if curves[name]}
            for name in RENDERERS:
                row[name] = None
                if name in found and found[name].status != "no_curve":
                    entry = found[name].as_dict()
                    seconds = entry["seconds"] or entry["bound_seconds"]
                    for clock in ("warm", "cold"):
                        entry[f"ratio_{clock}"] = seconds / row[f"lantern_{clock}_seconds"]
                    row[name] = entry
            # Lantern can win at its own error while a renderer's cheapest image is
            # already better: say so beside the winner.
            row["better_at_cheapest"] = [
                name for name, result in found.items() if result.status == "already_below"
                and result.bound_seconds > row["lantern_warm_seconds"]]
            for clock in ("warm", "cold"):
                times = {"lantern": (row[f"lantern_{clock}_seconds"],) * 2}
                times |= {name: _bounds(result) for name, result in found.items()
                          if _bounds(result) is not None}
                row[f"winner_{clock}"] = _winner(times)
            rows.append(row)
    return rows


def _score(options, out, references, jobs, film_transparent, view):
    """Every render's entry in results.json, its metrics against each mode's reference
    written in, its display image and FLIP heat maps written out."""
    from ..engine.image_io import read_exr
    from . import metrics, report

    lantern_jobs = [j for j in jobs if j.extra.get("renderer") == "lantern" and j.result]
    loaded = {mode: read_exr(r["image"]) for mode, r in references.items()
              if os.path.isfile(r["image"])}
    mask, mask_info = _mask(loaded, references, lantern_jobs, film_transparent)
    for mode, reference in references.items():
        reference["problems"] = metrics.problems(loaded[mode]) if mode in loaded else None
        if mode in loaded:
            reference["flip_parameters"] = metrics.flip_parameters(loaded[mode])
            reference["png"] = _rel(out, report.display_png(
                report.png_path(out, reference["image"]), loaded[mode], view))
    renders = []
    for job in jobs:
        renderer = job.extra.get("renderer")
        if renderer is None or job.result is None:
            continue
        if renderer == "lantern":
            entries = [{"id": f"lantern-{job.extra['mode']}-{job.extra['preset']}",
                        "renderer": "lantern", "preset": job.extra["preset"],
                        "mode": job.extra["mode"], "image": job.result["image"],
                        "seconds": job.result["warm_seconds"],
                        "cold_seconds": job.result["cold_seconds"],
                        "warm_runs": job.result["warm_runs"],
                        "export_seconds": job.result["export_seconds"],
                        "warnings": job.result["warnings"]}]
        else:
            entries = []
            for point in job.result["points"]:
                entry = {"id": f"{renderer}-{job.extra.get('mode', 'any')}-{point['samples']}",
                         "renderer": renderer, "samples": point["samples"],
                         "image": point["image"], "seconds": point["seconds"],
                         "runs": point["runs"],
                         "first_render_seconds": job.result["first_render_seconds"]}
                if renderer != "eevee":
                    entry |= {"mode": job.extra["mode"], "denoised": job.extra["denoised"]}
                entries.append(entry)
        for entry in entries:
            image = read_exr(entry["image"])
            entry["png"] = _rel(out, report.display_png(report.png_path(out, entry["image"]),
                                                        image, view))
            entry["metrics"] = {}
            entry["problems"] = metrics.problems(image)
            for mode, reference in loaded.items():
                if renderer != "eevee" and entry["mode"] != mode:
                    continue
                scored = metrics.score(image, reference, mask)
                heatmap = None
                if "hdr_flip" in scored["flip_maps"]:
                    heatmap = _rel(out, report.heatmap_png(
                        report.heatmap_path(out, entry["image"], mode),
                        scored["flip_maps"]["hdr_flip"]))
                entry["metrics"][mode] = {"all": scored["all"], "foreground": scored["foreground"],
                                          "heatmap": heatmap}
            renders.append(entry)
    return renders, mask_info


def _view(view):
    """The scene's view transform, look and exposure for the report's images, or
    Standard (with a note) when this machine's OpenColorIO config cannot apply them."""
    from ..engine.color import ColorManagementError, check
    try:
        check(view["transform"], view["look"], view["exposure"])
    except ColorManagementError as error:
        return ({"transform": "Standard", "look": None, "exposure": 0.0},
                [f"the report's images use the Standard view: {error}"])
    return view, []


def _ratio(x):
    return f"{x:.0f}" if x >= 100 else f"{x:.3g}"


def _summary(equal, renders, modes):
    """The one line on stdout: per mode, the best Lantern image against Cycles."""
    if len(modes) > 1:
        return " | ".join(f"{mode}: {_summary(equal, renders, (mode,))}" for mode in modes)
    rows = [r for r in equal if r["mode"] == modes[0]]
    if not rows:
        return "no Lantern image could be scored (see the report's failures)"
    best = min(rows, key=lambda r: (r["flip"], r["lantern_warm_seconds"]))
    text = (f"Lantern {best['preset']}: {best['lantern_warm_seconds']:.3g} s warm "
            f"({best['lantern_cold_seconds']:.3g} s cold), FLIP {best['flip']:.2g}")
    cycles = best["cycles"]
    if cycles is None:
        text += "; no Cycles curve"
    elif cycles["status"] == "reached":
        text += (f"; Cycles needs {cycles['seconds']:.3g} s for that FLIP "
                 f"({_ratio(cycles['ratio_warm'])}x)")
    elif cycles["status"] == "already_below":
        text += (f"; Cycles is already below it at {cycles['bound_samples']} spp "
                 f"({cycles['bound_seconds']:.3g} s, {_ratio(cycles['ratio_warm'])}x)")
    else:
        text += (f"; Cycles does not reach it by {cycles['bound_samples']} spp "
                 f"(> {cycles['bound_seconds']:.3g} s, > {_ratio(cycles['ratio_warm'])}x)")
    eevee = sweep_points(renders, "eevee", modes[0])
    if eevee:
        samples, seconds, flip = eevee[0]
        text += f"; EEVEE {samples} spp {seconds:.3g} s, FLIP {flip:.2g}"
    return text


def _timing_notes(options):
    notes = {
        "lantern_warm": (f"median of {options.warm_runs} renders of one engine.Session after "
                         "a warm-up render, the stage exported and read once (nothing "
                         "changes between renders, so nothing is read or uploaded again); "
                         "each builds the ray-tracing trees and the irradiance field from "
                         "nothing, as Cycles' time includes its BVH"),
        "lantern_cold": ("from the parent starting the worker process to Lantern's first "
                         "image in memory: process start, imports (bpy), opening the .blend, "
                         "the export to USD, the Session (stage read, GL context, uploads), "
                         "shader compilation, first render"),
        "cycles": ("wall time of bpy.ops.render.render(): the scene sync (geometry, BVH, "
                   "shaders, images) and the path tracing, not writing the file; after one "
                   "untimed 1-sample render in the same process; renders under 0.5 s are "
                   "the median of 3"),
        "eevee": ("wall time of bpy.ops.render.render() (scene sync and rendering), after one "
                  "untimed 1-sample render that compiles the shaders; under 0.5 s, median of 3"),
        "reference": "wall time of its one render call (cached references keep their first time)",
    }
    if options.jobs > 1:
        notes["parallel"] = (f"renders ran up to {options.jobs} at a time and shared the "
                             "machine's cores: their times are longer than alone")
    return notes


def compare(options: Options) -> dict:
    """Runs the comparison and writes the report; returns results.json's content."""
    from . import report
    if options.presets is None:
        options = dataclasses.replace(options, presets=preset_names())
    out = os.path.abspath(options.out)
    log_dir = os.path.join(out, "logs")
    os.makedirs(os.path.join(out, "images"), exist_ok=True)
    scan = _scan(options, log_dir)
    size = _size(options, scan["scene"])
    frame = float(options.frame if options.frame is not None else scan["scene"]["frame"])
    scene_files = reference_cache.scene_inputs(os.path.abspath(options.scene), scan["links"])
    jobs, references = _plan(options, out, scan, scene_files, size, frame)
    jobs = run_jobs(jobs, options.jobs, log_dir, quiet=options.quiet)
    _store_references(references)
    view, view_note = _view(scan["scene"]["view"])
    renders, mask_info = _score(options, out, references, jobs,
                                scan["scene"]["film_transparent"], view)
    equal = _equal_error(renders, options.modes, options.presets)

    warnings = list(dict.fromkeys([*options.extra_notes, *scan["notes"], *view_note,
                                   *(w for r in renders for w in r.get("warnings", []))]))
    results = {
        "schema": "lantern-compare/1",
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "scene": {"path": os.path.abspath(options.scene),
                  "sha256": scene_files["scene_sha256"],
                  "name": scan["scene"]["name"], "frame": frame, "size": list(size),
                  "film_transparent": scan["scene"]["film_transparent"],
                  "camera": scan["scene"]["camera"], "view": view},
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                    "blender": scan["scene"]["blender"], "lantern": installed_version()},
        "settings": {"presets": list(options.presets), "modes": list(options.modes),
                     "cycles_samples": list(options.cycles_samples),
                     "reference_samples": options.reference_samples,
                     "cycles_denoised": options.cycles_denoised, "eevee": options.eevee,
                     "eevee_samples": list(options.eevee_samples) if options.eevee else [],
                     "jobs": options.jobs, "warm_runs": options.warm_runs,
                     "pixel_filter": {"type": "BLACKMAN_HARRIS", "width": options.pixel_filter},
                     "seeds": {"reference": REFERENCE_SEED, "sweep": SWEEP_SEED},
                     "rel_mse_epsilon": 0.01},
        "links": scan["links"],
        "broken_links": [link for link in scan["links"] if not link["exists"]],
        "warnings": warnings,
        "timing": _timing_notes(options),
        "references": {mode: {k: v for k, v in r.items() if k != "cache"}
                       for mode, r in references.items()},
        "mask": mask_info,
        "renders": renders,
        "equal_error": equal,
        "failures": [{"job": j.name, "error": j.error, "log": j.log}
                     for j in jobs if j.error is not None],
    }
    results["summary"] = _summary(equal, renders, options.modes)
    results = _relative_paths(results, out)
    report.write(out, results)
    return results


def _relative_paths(results, out):
    """Every path inside the report folder relative to it (results.json's folder)."""
    for reference in results["references"].values():
        reference["image"] = _rel(out, reference["image"])
    results["mask"]["image"] = _rel(out, results["mask"]["image"])
    for render in results["renders"]:
        render["image"] = _rel(out, render["image"])
    for failure in results["failures"]:
        failure["log"] = _rel(out, failure["log"])
    return results
