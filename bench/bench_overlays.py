"""Overlays: what a burn-in and a watermark add to writing a .png, and how close the
distance-field text is to FreeType's outlines at each size.

Speed: the overlay pass (engine/gpu/overlays.py) against the view transform it follows
(engine/color.py to_display8), in the same run, at 1280x720 and 1920x1080.
Accuracy: mean coverage error on edge pixels and the share of edge pixels off by more
than 0.25, against the outline rasterised by FreeType (Pillow) at 8x and averaged."""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

from lantern.engine.color import to_display8                     # noqa: E402
from lantern.engine.overlays import BurnIn                        # noqa: E402


def _best(fn, repeats=5):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def speed():
    mark = np.zeros((64, 128, 4), np.uint8)
    mark[..., :3], mark[..., 3] = 255, 128
    for width, height in ((1280, 720), (1920, 1080)):
        linear = np.random.default_rng(1).random((height, width, 4), np.float32)
        display = to_display8(linear)
        burn = BurnIn("{scene} {camera} f{frame:04d} {date}", size=24,
                      values=dict(scene="shot010", camera="cam", preset="medium"),
                      watermark=mark)
        burn.apply(display, frame=1)      # compile programs once
        view = _best(lambda: to_display8(linear))
        over = _best(lambda: burn.apply(display, frame=1))
        print(f"{width}x{height}: view transform {view * 1000:.1f} ms, burn-in + watermark "
              f"{over * 1000:.1f} ms ({over / view:.2f}x the view transform)")


def accuracy():
    import test_overlays as t
    print("size  path    mean edge error  edge px off > 0.25")
    for size in (8, 12, 24, 48, 96, 200):
        ours, text = t._coverage(size, "sdf")
        reference = t._freetype(text, ours.shape[1], ours.shape[0],
                                supersample=8 if size <= 96 else 4)
        mean, wrong, _ = t._edge_figures(ours, reference)
        print(f"{size:4d}  sdf     {mean:.3f}            {wrong * 100:.1f} %")
    for size in (8, 12, 16):
        ours, text = t._coverage(size, "bitmap")
        reference = t._freetype(text, ours.shape[1], ours.shape[0], supersample=1)
        print(f"{size:4d}  bitmap  max {np.abs(ours - reference).max():.3f} against FreeType's "
              "hinted pixels")


if __name__ == "__main__":
    speed()
    accuracy()
