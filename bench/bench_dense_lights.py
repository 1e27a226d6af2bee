"""Many lights close together: 16,384 point lights of 2 mW, 3 cm apart in a 3.84 m
square patch 0.3 m over a white plane, no shadows, seen from straight above (an 8 m
wide orthographic view), 320x180 medium, AO and FXAA off; against one light of their
total power at the patch's centre. Every pixel under the patch has every light within
a few metres: the light tree's hardest case (engine/light_tree.py). Prints the warm
frame time and CPU time of each, the light passes' GPU time, the light tree's steps
per pixel (stats light_tree_steps over light_tree_pixels) and the error against
numpy's exact inverse-square sum on a grid of plane pixels. Asserts nothing. Runs
without Blender (usd-core).

    python bench/bench_dense_lights.py [--runs N]
"""
import argparse
import pathlib
import resource
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))

WIDTH, HEIGHT = 320, 180


def cpu_seconds():
    """This process's CPU time, llvmpipe's threads included."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def frame(session, runs):
    """(median warm frame seconds, median CPU seconds, last result). The CPU time is
    the steadier figure on a machine shared with other work, as this one is."""
    result = session.render()                    # warm: programs, tree, pool sized
    times, cpu = [], []
    for _ in range(runs):
        start, start_cpu = time.perf_counter(), cpu_seconds()
        result = session.render()
        times.append(time.perf_counter() - start)
        cpu.append(cpu_seconds() - start_cpu)
    return statistics.median(times), statistics.median(cpu), result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    from lantern.engine import RenderSettings, Session
    from test_light_tree import DENSE_EXTENT, DENSE_HEIGHT, dense_patch, dense_stage, \
        irradiance, wide_pixel_points
    lights = dense_patch()
    power = 0.002
    settings = RenderSettings(width=WIDTH, height=HEIGHT, preset="medium", lighting="clustered",
                              ambient_occlusion=False, fxaa=False)
    rows = {}
    for name, positions, watts in (("one", [(0.0, 0.0, DENSE_HEIGHT)], power * len(lights)),
                                   ("dense", lights, power)):
        stage = dense_stage(positions, watts, WIDTH, HEIGHT)
        with Session(stage, settings) as session:
            rows[name] = frame(session, args.runs)
    one, dense = rows["one"], rows["dense"]
    # The error: the plane's radiance per irradiance from the single light (its median
    # ratio), against the dense patch's image over its exact sum, on a grid of pixels.
    step = 10
    cols, lines = np.arange(step // 2, WIDTH, step), np.arange(step // 2, HEIGHT, step)
    X, Y = (a[lines][:, cols] for a in wide_pixel_points(DENSE_EXTENT, WIDTH, HEIGHT))
    scale = np.median(one[2].rgba[lines][:, cols, 0]
                      / (irradiance((X, Y), [(0.0, 0.0, DENSE_HEIGHT)]) * len(lights)))
    got = dense[2].rgba[lines][:, cols, 0].astype(np.float64)
    error = np.abs(got / (irradiance((X, Y), lights) * scale) - 1)
    print(f"dense lights at {WIDTH}x{HEIGHT} medium ({time.strftime('%Y-%m-%d')}):")
    for name, (seconds, cpu, result) in rows.items():
        gpu = result.gpu_timings
        light_ms = 1000 * (gpu.get("lights", 0.0) + gpu.get("light_cull", 0.0))
        steps = result.stats.get("light_tree_steps")
        pixels = result.stats.get("light_tree_pixels", 0)
        per_pixel = "" if steps is None else \
            f" | light tree steps per pixel {steps / max(pixels, 1):.1f}" \
            f" (most {result.stats['light_tree_steps_max']})"
        print(f"  {name:<6} frame {1000 * seconds:8.1f} ms, CPU {1000 * cpu:8.1f} ms | "
              f"light cull + lights GPU "
              f"{light_ms:8.1f} ms | light items {result.stats.get('light_items', 0)}"
              + per_pixel)
    print(f"  dense / one: frame {dense[0] / one[0]:.1f}x, CPU {dense[1] / one[1]:.1f}x; "
          f"error against the exact sum on "
          f"{error.size} pixels: max {100 * error.max():.3f}%, mean {100 * error.mean():.4f}%")


if __name__ == "__main__":
    main()
