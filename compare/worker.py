"""One render job in its own process: `python -m lantern.compare.worker SPEC.json`.

The parent (run.py) writes a spec, starts this process and reads back the result
file the spec names. Blender holds one scene per process, a crash in Blender fails
only its own job, and Lantern's cold time needs a fresh process anyway. Jobs:
- scan: what the .blend is (frame, size, camera, film) and the files it links;
- cycles: Cycles at each sample count of the spec (the reference is one of these);
- eevee: EEVEE at each sample count;
- lantern: Lantern at one preset, cold and warm (lantern_timing.py).
Each finished render prints a progress line (PROGRESS, then JSON) on stdout; a
failure ends with one line on stderr and exit status 1."""
from __future__ import annotations

import json
import statistics
import sys
import time

from ..core.text import error_text
from .modes import PROGRESS

# Short renders are repeated (median) so that one scheduler hiccup does not decide a
# point of the curve; a render longer than this is timed once.
REPEAT_BELOW_SECONDS = 0.5
REPEATS = 3


def _progress(**fields):
    print(PROGRESS, json.dumps(fields), flush=True)


def _scan(spec):
    import bpy
    from .blender_scene import describe, links, open_scene
    notes = open_scene(spec["scene"])
    return {"scene": describe(bpy.context.scene), "links": links(), "notes": notes}


def _blender(spec):
    import bpy
    from . import blender_render
    from .blender_scene import open_scene
    notes = open_scene(spec["scene"], spec["frame"], spec["size"])
    scene = bpy.context.scene
    blender_render.prepare_output(scene)
    engine = spec["engine"]

    def configure(samples):
        if engine == "cycles":
            return blender_render.configure_cycles(
                scene, samples, spec["seed"], spec["mode"], spec["denoise"], spec["filter_width"])
        blender_render.configure_eevee(scene, samples)
        return {}

    first_render_seconds = None
    if spec.get("warm_up", True):
        configure(1)
        first_render_seconds = blender_render.render(scene)
    points = []
    for samples, path in zip(spec["samples"], spec["images"]):
        light_paths = configure(samples)
        times = [blender_render.render(scene, path)]
        while times[0] < REPEAT_BELOW_SECONDS and len(times) < REPEATS and spec.get("repeat", True):
            times.append(blender_render.render(scene))
        points.append({"samples": samples, "image": path, "seconds": statistics.median(times),
                       "runs": times})
        _progress(task=spec["name"], samples=samples, seconds=points[-1]["seconds"])
    return {"points": points, "first_render_seconds": first_render_seconds,
            "light_paths": light_paths if engine == "cycles" else None, "notes": notes}


def _lantern(spec):
    from ..engine.image_io import write_image
    from .lantern_timing import time_lantern
    timed = time_lantern(spec["scene"], spec["frame"], tuple(spec["size"]), spec["preset"],
                         spec["transparent"], spec["spawned_at"], spec["warm_runs"],
                         coverage=spec.get("coverage") is not None,
                         antialias=spec.get("antialias", True),
                         direct=spec.get("direct", False))
    write_image(spec["image"], timed.pop("rgba"))
    coverage = timed.pop("coverage")
    if coverage is not None:
        import numpy as np
        write_image(spec["coverage"], np.repeat(coverage[..., None], 4, axis=-1))
    _progress(task=spec["name"], seconds=timed["warm_seconds"])
    return timed | {"image": spec["image"], "coverage": spec.get("coverage")}


JOBS = {"scan": _scan, "cycles": _blender, "eevee": _blender, "lantern": _lantern}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    with open(argv[0], encoding="utf-8") as f:
        spec = json.load(f)
    import lantern.exporters  # noqa: F401  (Blender's own pxr first, in every job)
    from .files import write_json
    try:
        result = JOBS[spec["job"]](spec)
    except Exception as error:  # one line for the report; --debug-like detail in the log
        import traceback
        traceback.print_exc()
        print(f"error: {type(error).__name__}: {error_text(error)}".splitlines()[0],
              file=sys.stderr)
        return 1
    result["finished_at"] = time.time()
    write_json(spec["result"], result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
