"""Exports and renders every .blend file in a folder, each step in its own process with a
timeout, and prints what happened: how many exported and rendered, every failure with
its reason, images that came out empty or flat, and scenes with instances.

    python bench/sweep_scenes.py FOLDER [--size 96x54] [--timeout 180] [-j 1] [--out DIR]

FOLDER is e.g. glTF-Blender-IO's `tests/scenes` (169 .blend files), checked out outside
the repository. Not part of `make test`: it takes minutes, and the scenes are not ours.
The render reads the exported USD file (usd-core, no bpy), as a pipeline would.
"""
import argparse
import collections
import pathlib
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

# An image whose pixels vary less than this (max - min of luminance) shows nothing.
FLAT = 1e-4


def _run(command, timeout):
    """(exit status or 'timeout', stdout, stderr, seconds)."""
    start = time.perf_counter()
    try:
        proc = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
        status = proc.returncode
        out, err = proc.stdout, proc.stderr
    except subprocess.TimeoutExpired as timeout_error:
        status, out, err = "timeout", timeout_error.stdout or "", timeout_error.stderr or ""
        out = out.decode() if isinstance(out, bytes) else out
        err = err.decode() if isinstance(err, bytes) else err
    return status, out, err, time.perf_counter() - start


def _reason(status, err):
    if status == "timeout":
        return "timeout"
    if isinstance(status, int) and status < 0:
        return f"crashed (signal {-status})"
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("warning: ")]
    if any(line.startswith("Traceback") for line in lines):
        return "traceback: " + lines[-1][:160]
    return lines[-1][:160] if lines else f"exit status {status}, no message"


def _usd_facts(path):
    """Prim kinds the exported file holds (read in this process with usd-core)."""
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.Open(str(path))
    facts = collections.Counter()
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()):
        if prim.IsA(UsdGeom.PointInstancer):
            facts["point instancers"] += 1
            facts["instances"] += len(UsdGeom.PointInstancer(prim).GetProtoIndicesAttr().Get() or [])
        elif prim.IsA(UsdGeom.Points):
            facts["points prims"] += 1
    return facts


def _image_kind(path):
    from lantern.engine.image_io import read_exr
    import numpy as np
    rgba = read_exr(str(path))
    if not np.isfinite(rgba).all():
        return "non-finite"
    lum = rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    if float(np.abs(rgba[..., :3]).max()) == 0.0:
        return "empty"
    if float(lum.max() - lum.min()) < FLAT:
        return "flat"
    return "ok"


def sweep_one(blend, out_dir, size, timeout):
    stem = blend.stem
    usd = out_dir / f"{stem}.usdc"
    exr = out_dir / f"{stem}.exr"
    row = {"scene": blend.name}
    status, out, err, seconds = _run([sys.executable, "-m", "lantern", "export", str(blend),
                                      "-o", str(usd)], timeout)
    warnings = [line for line in err.splitlines() if line.startswith("warning: ")]
    # A message printed twice (once by a logger, once by the CLI) counts as repeated.
    messages = [line.removeprefix("warning: ") for line in err.splitlines() if line.strip()]
    row.update(export_seconds=seconds, warnings=len(warnings),
               repeated_warnings=len(messages) - len(set(messages)),
               instance_warning=any("instance" in w for w in warnings))
    if status != 0 or not usd.is_file():
        row.update(exported=False, reason=_reason(status, err))
        return row
    row.update(exported=True, facts=_usd_facts(usd))
    status, out, err, seconds = _run([sys.executable, "-m", "lantern", "render", str(usd),
                                      "-o", str(exr), "--size", size], timeout)
    row["render_seconds"] = seconds
    if status != 0 or not exr.is_file():
        row.update(rendered=False, reason=_reason(status, err))
        return row
    row.update(rendered=True, image=_image_kind(exr))
    facts = row["facts"]
    if facts["point instancers"] or facts["points prims"]:
        # Whether the engine draws them: its own counts, from a render of the file.
        code = ("import sys; from lantern.engine import RenderSettings, render_file; "
                f"r = render_file(sys.argv[1], RenderSettings(width={size.split('x')[0]}, "
                f"height={size.split('x')[1]})); "
                "print(r.stats['instances_drawn'], r.stats['points_drawn'])")
        status, out, err, _ = _run([sys.executable, "-c", code, str(usd)], timeout)
        drawn = out.split() if status == 0 else []
        row.update(instances_drawn=int(drawn[0]) if drawn else -1,
                   points_drawn=int(drawn[1]) if drawn else -1)
    return row


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=pathlib.Path)
    parser.add_argument("--size", default="96x54")
    parser.add_argument("--timeout", type=float, default=180.0, help="seconds per step")
    parser.add_argument("-j", "--jobs", type=int, default=1)
    parser.add_argument("--out", type=pathlib.Path, default=None,
                        help="keep the USD files and images here (default: a temp folder)")
    parser.add_argument("--only", nargs="*", default=None, help="scene file names to run")
    args = parser.parse_args(argv)
    blends = sorted(args.folder.glob("*.blend"))
    if args.only:
        blends = [b for b in blends if b.name in args.only or b.stem in args.only]
    if not blends:
        print(f"{args.folder}: no .blend files", file=sys.stderr)
        return 2
    temp = None
    if args.out is None:
        temp = tempfile.TemporaryDirectory(prefix="lantern-sweep-")
        out_dir = pathlib.Path(temp.name)
    else:
        out_dir = args.out
        out_dir.mkdir(parents=True, exist_ok=True)

    start = time.perf_counter()
    rows = []
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for row in pool.map(lambda b: sweep_one(b, out_dir, args.size, args.timeout), blends):
            rows.append(row)
            state = ("export failed" if not row["exported"] else
                     "render failed" if not row.get("rendered") else row["image"])
            print(f"{len(rows):4d}/{len(blends)} {row['scene']:<48} {state}"
                  + (f"  ({row['reason']})" if "reason" in row else ""), flush=True)

    exported = [r for r in rows if r["exported"]]
    rendered = [r for r in exported if r.get("rendered")]
    facts = collections.Counter()
    for r in exported:
        facts.update(r["facts"])
    images = collections.Counter(r["image"] for r in rendered)
    print(f"\n{len(blends)} scenes in {args.folder} ({time.perf_counter() - start:.0f} s)")
    print(f"exported: {len(exported)}")
    print(f"rendered: {len(rendered)}")
    print(f"images: {dict(sorted(images.items()))}  (flat: luminance range < {FLAT})")
    print(f"scenes with point instancers: {sum(1 for r in exported if r['facts']['point instancers'])}"
          f" ({facts['point instancers']} instancers, {facts['instances']} instances)")
    print(f"scenes with Points prims: {sum(1 for r in exported if r['facts']['points prims'])}")
    inst = [r for r in rendered if r["facts"]["point instancers"]]
    pts = [r for r in rendered if r["facts"]["points prims"]]
    print(f"instanced scenes whose instances the engine draws: "
          f"{sum(1 for r in inst if r.get('instances_drawn', 0) > 0)} of {len(inst)} "
          f"({sum(max(r.get('instances_drawn', 0), 0) for r in inst)} instances in view)")
    print(f"Points scenes whose points the engine draws: "
          f"{sum(1 for r in pts if r.get('points_drawn', 0) > 0)} of {len(pts)}")
    print(f"scenes warning about instances: {sum(1 for r in rows if r['instance_warning'])}")
    print(f"warnings: {sum(r['warnings'] for r in rows)}, printed more than once: "
          f"{sum(r['repeated_warnings'] for r in rows)}")
    failures = [r for r in rows if "reason" in r]
    if failures:
        print("failed:")
        for r in failures:
            step = "export" if not r["exported"] else "render"
            print(f"  {r['scene']}: {step}: {r['reason']}")
    not_ok = [r for r in rendered if r["image"] != "ok"]
    if not_ok:
        print("empty, flat or non-finite images:")
        for r in not_ok:
            print(f"  {r['scene']}: {r['image']}")
    if temp is not None:
        temp.cleanup()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
