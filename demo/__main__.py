"""`make demo`: build the demo scene, export it with `lantern export`, render it with
`lantern render` (a process without bpy, on usd-core): frame 13 as EXR and PNG, and
the rig's animation (frames 1-24) as a GIF. Prints what was measured."""
import os
import subprocess
import sys
import time

OUT = "out"


def _run(*args):
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "lantern", *args], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    sys.stdout.write(proc.stdout)
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr)
        raise SystemExit(f"demo: `lantern {' '.join(args)}` failed ({proc.returncode})")
    warnings = [line for line in proc.stderr.splitlines() if line.startswith("warning:")]
    return seconds, warnings


def main():
    os.makedirs(OUT, exist_ok=True)
    blend = os.path.join(OUT, "demo.blend")
    usd = os.path.join(OUT, "demo.usdc")
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c",
                    "import lantern.exporters, sys; from lantern.demo.build_scene import build; "
                    "build(sys.argv[1])", blend], check=True, capture_output=True)
    build_s = time.perf_counter() - start
    export_s, export_warnings = _run("export", blend, "-o", usd)
    render_exr_s, render_warnings = _run("render", usd, "-o", os.path.join(OUT, "demo.exr"),
                                         "--frame", "13")
    render_png_s, _ = _run("render", usd, "-o", os.path.join(OUT, "demo.png"), "--frame", "13")
    gif_s, _ = _run("render", usd, "--frames", "1:24", "--size", "320x180",
                    "-o", os.path.join(OUT, "demo.gif"))

    import numpy as np
    from lantern.engine.image_io import read_exr
    rgba = read_exr(os.path.join(OUT, "demo.exr"))
    print()
    print("Lantern demo: measured")
    print(f"  build scene (bpy)        {build_s:7.2f} s  -> {blend}")
    print(f"  export (lantern export)  {export_s:7.2f} s  -> {usd}  ({len(export_warnings)} warnings)")
    print(f"  render EXR (no bpy)      {render_exr_s:7.2f} s  -> {OUT}/demo.exr  {rgba.shape[1]}x{rgba.shape[0]}")
    print(f"  render PNG (no bpy)      {render_png_s:7.2f} s  -> {OUT}/demo.png")
    print(f"  24 frames, GPU skinning  {gif_s:7.2f} s  -> {OUT}/demo.gif  320x180 "
          f"({gif_s / 24 * 1000:.0f} ms a frame, process start included)")
    print(f"  image: mean radiance {rgba[..., :3].mean():.4f}, max {rgba[..., :3].max():.3f}, "
          f"finite {bool(np.isfinite(rgba).all())}")
    for warning in export_warnings + render_warnings:
        print(f"  {warning}")


if __name__ == "__main__":
    main()
