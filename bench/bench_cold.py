"""Cold start: what Lantern costs before its first image, against its warm render.
Prints figures (medians of several new processes), asserts nothing.

  1. `lantern render out/demo.usdc -o X.png --size 640x360 --timings`, each run a new
     process, its phases as --timings prints them and its wall time seen from here:
     - program cache empty (a new folder each run), then warm (one folder, filled);
     - no program cache (LANTERN_NO_PROGRAM_CACHE=1);
     - the code before (`git archive` of --baseline, default the commit where this
       branch left main, run in its place);
     - the driver's own shader cache off too (MESA_SHADER_CACHE_DISABLE=true, and
       NVIDIA's __GL_SHADER_DISK_CACHE=0), the cold of a machine that never rendered
       (Mesa then offers no program binary format, so Lantern's cache cannot help there);
     against warm `Session.render`s of the same view in this process: a frame that
     keeps its trees and irradiance field, and a still that builds them again (as every
     still does, and as `lantern compare` times Lantern warm).
  2. the first F12 of the demo (out/demo.blend at 640x360) in a new Blender process
     (bpy, the add-on registered from this checkout) against its second F12: without
     the prestart (F12 starts the engine host), with it and F12 at once after the file
     loads, and with it once the host has warmed up (a user who looks at the file for a
     moment); and that last as users run it: `make extension`'s zip installed into a
     Blender that lacks every module a real one lacks (as tests/test_addon_install.py
     does). Goal: first <= second + 0.3 s.
  3. the cold column of `lantern compare` (compare/lantern_timing.py: a Blender worker
     from its spawn to Lantern's first image) on three corpus scenes at 160x90, with the
     program cache empty and warm, and with the code before.

    .venv/bin/python bench/bench_cold.py [--runs 5] [--baseline REV|none] [--parts cli,f12,compare]
                                         [--demo USD]

`--parts cli --baseline none --demo FILE` runs without bpy or git (the GPU machine,
../shared/gpu/README.md).
"""
import argparse
import json
import os
import pathlib
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parent.parent
DEMO = REPO / "out" / "demo.usdc"
CORPUS = REPO.parent / "shared" / "corpus" / "blender"
COMPARE_SCENES = ("01_cube.blend", "02_suzanne.blend", "04_lights.blend")
SIZE = (640, 360)

PHASE_LINE = re.compile(r"^  (\S.*?)\s+(-?\d+\.\d)$")

# A `lantern compare` worker's timing of Lantern, cold (compare/lantern_timing.py).
COMPARE_COLD = """
import json, sys
spawned_at = float(sys.argv[2])
from lantern.compare.lantern_timing import time_lantern
timed = time_lantern(sys.argv[1], None, (160, 90), "medium", False, spawned_at, 3)
print(json.dumps({"cold": timed["cold_seconds"], "warm": timed["warm_seconds"]}))
"""


# What both F12 scripts below share: waiting for the engine host's warm-up, and two F12s
# timed (printed as seconds, the last line).
F12_COMMON = """
import json, sys, time


def wait_for_warm_up(log):
    deadline = time.monotonic() + 60           # at most a minute
    while not any("warmed up" in line for line in log()) and time.monotonic() < deadline:
        time.sleep(0.02)


def two_f12s():
    import bpy
    times = []
    for _ in range(2):
        start = time.perf_counter()
        bpy.ops.render.render()
        times.append(time.perf_counter() - start)
    print(json.dumps(times))
"""

# A new Blender: the add-on, the file, two F12s.
F12 = F12_COMMON + """
import lantern.exporters  # noqa: F401  (Blender's pxr first)
import bpy
import lantern
from lantern.addon import host, prestart
lantern.register()
if sys.argv[2] == "off":
    prestart.unregister()
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
if sys.argv[2] == "idle":
    wait_for_warm_up(lambda: host.get().log)
two_f12s()
lantern.unregister()
"""

# As F12 in "idle" mode, but as users get Lantern: the extension zip installed into a
# bpy process that hides every module a real Blender lacks, here and in the engine
# host's child (tests/blender_only/sitecustomize.py, as tests/_addon_host.py does).
F12_INSTALLED = F12_COMMON + """
import importlib.util, os, shutil, tempfile
blend, zip_path, blender_only = sys.argv[1], sys.argv[3], sys.argv[4]
spec = importlib.util.spec_from_file_location("blender_only",
                                              os.path.join(blender_only, "sitecustomize.py"))
spec.loader.exec_module(importlib.util.module_from_spec(spec))
os.environ["PYTHONPATH"] = blender_only
user = tempfile.mkdtemp(prefix="blender-user-")
os.environ["BLENDER_USER_RESOURCES"] = user
import bpy
bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                         enable_on_install=True)
host = sys.modules["bl_ext.user_default.lantern.addon.host"]
bpy.ops.wm.open_mainfile(filepath=blend)
wait_for_warm_up(lambda: host.get().log)
two_f12s()
bpy.ops.preferences.addon_disable(module="bl_ext.user_default.lantern")
shutil.rmtree(user, ignore_errors=True)
"""

# The demo as an F12 of 640x360 with Lantern.
F12_FILE = """
import sys
import bpy
import lantern
lantern.register()          # the LANTERN engine, to be chosen
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
for scene in bpy.data.scenes:
    scene.render.engine = "LANTERN"
    scene.render.resolution_x, scene.render.resolution_y = %d, %d
    scene.render.resolution_percentage = 100
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[2])
""" % SIZE


def first_f12(blend, mode, env, extension=None):
    script, extra = F12, []
    if mode == "installed":
        script, extra = F12_INSTALLED, [str(extension), str(REPO / "tests" / "blender_only")]
    proc = subprocess.run([sys.executable, "-c", script, str(blend), mode, *extra],
                          capture_output=True, text=True, env=env, cwd=tempfile.gettempdir())
    if proc.returncode != 0:
        raise SystemExit(f"the F12 run failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def environment(cache=None, no_cache=False, mesa_off=False, code=None):
    env = dict(os.environ)
    for name in ("LANTERN_PROGRAM_CACHE_DIR", "LANTERN_NO_PROGRAM_CACHE",
                 "MESA_SHADER_CACHE_DISABLE", "__GL_SHADER_DISK_CACHE"):
        env.pop(name, None)
    if cache is not None:
        env["LANTERN_PROGRAM_CACHE_DIR"] = str(cache)
    if no_cache:
        env["LANTERN_NO_PROGRAM_CACHE"] = "1"
    if mesa_off:
        env["MESA_SHADER_CACHE_DISABLE"] = "true"
        env["__GL_SHADER_DISK_CACHE"] = "0"
    if code is not None:          # ahead of the editable install's finder
        env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(code), env.get("PYTHONPATH"))))
    return env


def cli_cold(env, out):
    """(phases in ms, programs line) of one `lantern render` in a new process; the
    wall time seen from here is the phase 'spawn to exit'."""
    start, cpu = time.perf_counter(), _children_cpu()
    proc = subprocess.run([sys.executable, "-m", "lantern", "render", str(DEMO), "-o", str(out),
                           "--size", f"{SIZE[0]}x{SIZE[1]}", "--timings"],
                          capture_output=True, text=True, env=env, cwd=REPO)
    wall = time.perf_counter() - start
    if proc.returncode == 2 and "--timings" in proc.stderr:      # code from before --timings
        start, cpu = time.perf_counter(), _children_cpu()
        proc = subprocess.run([sys.executable, "-m", "lantern", "render", str(DEMO), "-o",
                               str(out), "--size", f"{SIZE[0]}x{SIZE[1]}"],
                              capture_output=True, text=True, env=env, cwd=REPO)
        wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"lantern render failed:\n{proc.stderr}")
    phases, programs = {}, ""
    for line in proc.stdout.splitlines():
        match = PHASE_LINE.match(line)
        if match:
            phases[match.group(1)] = float(match.group(2))
        elif line.strip().startswith("programs:"):
            programs = line.strip()[len("programs: "):]
        elif line.strip().startswith("first frame's heaviest"):
            programs += "; " + line.strip()
    phases["spawn to exit"] = wall * 1000.0
    # CPU seconds of the process and its threads (llvmpipe draws on every core): less
    # sensitive than wall time to what else the machine runs.
    phases["CPU, user + system"] = (_children_cpu() - cpu) * 1000.0
    return phases, programs


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def medians(runs):
    names = list(dict.fromkeys(name for phases, _ in runs for name in phases))
    return {name: statistics.median(p[name] for p, _ in runs if name in p) for name in names}


def warm_session(runs):
    """{reference: (wall, CPU) median seconds} of warm Session.renders of the demo's view
    at 640x360 (the CLI's preset), in this process (CPU: of the process and all its
    threads, llvmpipe's included, as the cold processes' figure). Two references:
    "frame": a render of a Session that rendered before, which keeps its trees and its
    irradiance field (a viewport's steady frame); "still": the same with the trees and
    the field built from nothing (Session.drop_traced), as every still builds them and as
    `lantern compare` times Lantern warm."""
    from lantern.engine import RenderSettings, Session
    from lantern.engine.usd.opening import open_stage
    out = {}
    with Session(open_stage(str(DEMO)), RenderSettings(width=SIZE[0], height=SIZE[1])) as s:
        s.render()
        s.render()
        for reference in ("frame", "still"):
            times, cpu = [], []
            for _ in range(runs):
                if reference == "still":
                    s.drop_traced()
                start, used = time.perf_counter(), _own_cpu()
                s.render()
                times.append(time.perf_counter() - start)
                cpu.append(_own_cpu() - used)
            out[reference] = statistics.median(times), statistics.median(cpu)
    return out


def _own_cpu():
    t = os.times()
    return t.user + t.system


def compare_cold(blend, env):
    spawned_at = time.time()
    proc = subprocess.run([sys.executable, "-c", COMPARE_COLD, str(blend), repr(spawned_at)],
                          capture_output=True, text=True, env=env, cwd=REPO)
    if proc.returncode != 0:
        raise SystemExit(f"{blend}: the compare worker failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def baseline_code(rev, folder):
    """The package as of `rev`, extracted as folder/lantern (PYTHONPATH=folder)."""
    package = folder / "lantern"
    package.mkdir(parents=True)
    archive = subprocess.run(["git", "archive", rev], cwd=REPO, capture_output=True, check=True)
    subprocess.run(["tar", "-x", "-C", str(package)], input=archive.stdout, check=True)
    # Its bytecode written ahead, as `make` writes this checkout's: where
    # PYTHONDONTWRITEBYTECODE is set, each of its processes would compile it again.
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(package)], check=True,
                   capture_output=True)
    commit = subprocess.run(["git", "rev-parse", "--short", rev], cwd=REPO, capture_output=True,
                            text=True, check=True).stdout.strip()
    return folder, commit


def cli_part(args, tmp, code, commit, warm_cache):
    out = tmp / "demo.png"
    conditions = {      # column: its environment for run i
        "cache empty": lambda i: environment(cache=tmp / f"empty-{i}"),
        "cache warm": lambda i: environment(cache=warm_cache),
        "cache off": lambda i: environment(no_cache=True),
        f"before {commit}": lambda i: environment(code=code),
        "driver cache off": lambda i: environment(no_cache=True, mesa_off=True),
    }
    if code is None:
        del conditions[f"before {commit}"]
    table, programs = {}, {}
    for i in range(args.runs):      # interleaved, so that the machine's load is shared
        for name, env in conditions.items():
            run = cli_cold(env(i), out)
            table.setdefault(name, []).append(run)
            programs[name] = run[1]
    warm = warm_session(max(args.runs, 5))

    print(f"`lantern render {DEMO.name} -o demo.png --size {SIZE[0]}x{SIZE[1]}`, "
          f"medians of {args.runs} new processes (ms); cache: Lantern's program cache; "
          "driver cache off: the driver's shader cache and Lantern's off:")
    columns = list(conditions)
    rows = medians([r for name in columns for r in table[name]])
    width = max(len(c) for c in columns)
    print(f"  {'phase':<24}" + "".join(f"{c[:width]:>{width + 2}}" for c in columns))
    for phase in rows:
        cells = []
        for name in columns:
            values = [p[phase] for p, _ in table[name] if phase in p]
            cells.append(f"{statistics.median(values):{width + 2}.0f}" if values
                         else f"{'-':>{width + 2}}")
        print(f"  {phase:<24}" + "".join(cells))
    for name in columns:
        if programs[name]:
            print(f"  {name}: programs {programs[name]}")
    for reference, (wall_s, cpu_s) in warm.items():
        what = ("its trees and irradiance field kept" if reference == "frame" else
                "its trees and irradiance field built again, as every still builds them")
        print(f"warm Session.render of the same view, {what}: {wall_s * 1000:.0f} ms, CPU "
              f"{cpu_s * 1000:.0f} ms (the process and its threads)")
        for name in columns:
            wall = statistics.median(p["spawn to exit"] for p, _ in table[name])
            cpu = statistics.median(p["CPU, user + system"] for p, _ in table[name])
            print(f"  {name}: {wall:.0f} ms = warm {reference} + {wall - wall_s * 1000:.0f} ms; "
                  f"CPU {cpu:.0f} ms = warm {reference} + {cpu - cpu_s * 1000:.0f} ms")


def f12_part(args, tmp, warm_cache):
    print(f"F12 of the demo at {SIZE[0]}x{SIZE[1]} in a new Blender, median of "
          f"{args.runs} (ms), program cache warm:")
    blend = tmp / "f12.blend"
    subprocess.run([sys.executable, "-c", F12_FILE, str(REPO / "out" / "demo.blend"),
                    str(blend)], check=True, capture_output=True, env=environment(), cwd=REPO)
    modes = {"off": "no prestart (F12 starts the host)",
             "at once": "prestart, F12 as the file loads",
             "idle": "prestart, F12 once the host is warm",
             "installed": "idle, installed, modules hidden"}
    built = subprocess.run(["make", "--no-print-directory", "extension"], cwd=REPO,
                           capture_output=True, text=True)
    if built.returncode != 0:
        raise SystemExit(f"make extension failed:\n{built.stdout[-2000:]}{built.stderr[-2000:]}")
    extension = sorted((REPO / "dist").glob("lantern-*.zip"))[-1]
    f12 = {mode: [] for mode in modes}
    for _ in range(args.runs):
        for mode in modes:
            f12[mode].append(first_f12(blend, mode, environment(cache=warm_cache), extension))
    for mode, label in modes.items():
        first = statistics.median(t[0] for t in f12[mode]) * 1000
        second = statistics.median(t[1] for t in f12[mode]) * 1000
        print(f"  {label:<40} first {first:6.0f}  second {second:6.0f}  "
              f"(+{first - second:.0f})")


def compare_part(args, tmp, code):
    print("`lantern compare`'s cold column (a Blender worker from spawn to Lantern's "
          f"first image, 160x90, medium), median of {args.runs} (s):")
    print(f"  {'scene':<18}{'before':>10}{'cache empty':>13}{'cache warm':>12}{'warm render':>13}")
    for blend in COMPARE_SCENES:
        path = CORPUS / blend
        cells = {"before": [], "empty": [], "warm": [], "render": []}
        scene_cache = tmp / f"compare-{blend}"
        compare_cold(path, environment(cache=scene_cache))    # fills it
        for i in range(args.runs):
            cells["before"].append(compare_cold(path, environment(code=code))["cold"])
            cells["empty"].append(compare_cold(
                path, environment(cache=tmp / f"compare-empty-{blend}-{i}"))["cold"])
            timed = compare_cold(path, environment(cache=scene_cache))
            cells["warm"].append(timed["cold"])
            cells["render"].append(timed["warm"])
        m = {k: statistics.median(v) for k, v in cells.items()}
        print(f"  {blend[:-6]:<18}{m['before']:10.2f}{m['empty']:13.2f}{m['warm']:12.2f}"
              f"{m['render']:13.4f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--baseline", default=None,
                        help="git revision of the code before (default: git merge-base HEAD main)")
    parser.add_argument("--parts", default="cli,f12,compare",
                        help="which parts to run, of cli, f12 and compare")
    parser.add_argument("--demo", type=pathlib.Path, help="the USD file of the cli part")
    args = parser.parse_args()
    global DEMO
    DEMO = (args.demo or DEMO).resolve()
    parts = set(args.parts.split(","))
    if not DEMO.is_file():
        print("out/demo.usdc is missing: building it (make demo)", flush=True)
        subprocess.run([sys.executable, "-m", "lantern.demo"], cwd=REPO, check=True)

    with tempfile.TemporaryDirectory(prefix="lantern-bench-cold-") as tmp:
        tmp = pathlib.Path(tmp)
        code, commit = None, None
        if args.baseline != "none":
            rev = args.baseline or subprocess.run(
                ["git", "merge-base", "HEAD", "main"], cwd=REPO, capture_output=True,
                text=True, check=True).stdout.strip()
            code, commit = baseline_code(rev, tmp / "baseline")
        warm_cache = tmp / "warm-cache"
        os.environ["LANTERN_PROGRAM_CACHE_DIR"] = str(warm_cache)   # this process's too
        cli_cold(environment(cache=warm_cache), tmp / "demo.png")   # fills the warm cache
        if "cli" in parts:
            cli_part(args, tmp, code, commit, warm_cache)
        if "f12" in parts:
            print()
            f12_part(args, tmp, warm_cache)
        if "compare" in parts:
            print()
            compare_part(args, tmp, code)


if __name__ == "__main__":
    main()
