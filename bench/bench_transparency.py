"""Transparency and area-light shadows (docs/rendering.md): error against Cycles next to time.
Prints; asserts nothing.

1. The transparency scenes against their Cycles references (tests/references/looks),
   medium preset: mean HDR-FLIP before the shading work (BEFORE.md) and now, render time.
2. Hashed alpha, blended or stochastic: transparency_planes with its materials set to
   Blender's Dithered render method. Both treatments are composed from the same
   per-layer renders (each plane alone, opaque; none), so they differ only in how
   the layers combine: blended ("over", what Lantern draws) or stochastic (each
   pixel keeps each layer with probability alpha, as a hashed G-buffer would, at 1
   and at 4 samples a pixel). Inter-layer shadows are absent from both.
3. Transparent shadows: light through one and two layers of opacity 0.5 (closed
   forms 0.5 and 0.25), and the pixel noise of the stochastic shadow map, by preset.
4. Area lights: the penumbra scenes (tests/penumbra_scenes.py) against Cycles, FLIP
   and the penumbra's light ratio, and the light pass's time against the same light
   without shadows (medians of interleaved runs).
5. The transparency pass's cost: the three planes blended against the same planes
   opaque, 320 x 180.

    .venv/bin/python bench/bench_transparency.py
"""
import pathlib
import sys
import time

TESTS = pathlib.Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import lantern.exporters  # noqa: F401,E402  (Blender's pxr first)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import penumbra_scenes  # noqa: E402
import reference_scenes  # noqa: E402
import transparency_scenes as T  # noqa: E402
from image_metrics import mean_flip, psnr  # noqa: E402
from lantern.engine import RenderSettings, Session, read_exr, render_stage  # noqa: E402
from lantern.exporters import stage_from_depsgraph  # noqa: E402

LOOKS = TESTS / "references" / "looks"
WORKDIR = "/tmp/lantern-reference-textures"


def before(name):
    for line in (LOOKS / "BEFORE.md").read_text().splitlines():
        cells = [c.strip() for c in line.split("|")]
        if len(cells) > 2 and cells[1] == name:
            return float(cells[2])
    return float("nan")


def warm_ms(stage, settings, runs=3):
    render_stage(stage, settings)
    times, result = [], None
    for _ in range(runs):
        t = time.perf_counter()
        result = render_stage(stage, settings)
        times.append(time.perf_counter() - t)
    return result, 1000 * float(np.median(times))


def looks():
    print("\n1. transparency scenes vs Cycles (medium)")
    print(f"{'scene':<22}{'before':>8}{'FLIP':>8}{'PSNR':>7}{'ms':>7}")
    for name in ("transparency_planes", "cutout_shadow", "01_alpha_blend", "01_alpha_mask"):
        reference_scenes.build(name, WORKDIR)
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        w, h = reference_scenes.SCENES[name].size
        result, ms = warm_ms(stage, RenderSettings(width=w, height=h))
        ref = read_exr(str(LOOKS / f"{name}.exr"))
        print(f"{name:<22}{before(name):>8.4f}{mean_flip(result.rgba, ref):>8.4f}"
              f"{psnr(result.rgba, ref):>7.2f}{ms:>7.0f}")


def hashed():
    print("\n2. hashed alpha: blended vs stochastic, transparency_planes (Dithered), medium")
    reference_scenes.build("transparency_planes", WORKDIR)
    names = ("Red", "Green", "Blue")
    for name in names:
        bpy.data.materials[name].surface_render_method = 'DITHERED'
    w, h = reference_scenes.SCENES["transparency_planes"].size
    settings = RenderSettings(width=w, height=h)
    ref = read_exr(str(LOOKS / "transparency_planes.exr"))
    full, _ = warm_ms(stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())[0], settings, 1)

    def layer_render(opaque):
        for name in names:
            bsdf = bpy.data.materials[name].node_tree.nodes["Principled BSDF"]
            bsdf.inputs["Alpha"].default_value = 1.0 if name == opaque else 0.0
        stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
        return render_stage(stage, settings)

    # Each plane alone (opaque), with its coverage; the backdrop alone.
    layers = {}
    for name in names:
        r = layer_render(name)
        layers[name] = r.rgba[..., :3]
    background = layer_render(None).rgba[..., :3]
    # Which plane a pixel shows, front to back: the camera looks along +y, planes at
    # y = -1 (red), 0 (green), 1 (blue); a plane covers a pixel where it changed it.
    cover = {n: np.abs(layers[n] - background).max(-1) > 1e-4 for n in names}
    alpha = 0.5
    blended = background.copy()
    for n in reversed(names):                           # back to front
        blended = np.where(cover[n][..., None], alpha * layers[n] + (1 - alpha) * blended, blended)
    rng = np.random.default_rng(1)

    def stochastic(samples):
        out = np.zeros_like(background)
        for _ in range(samples):
            img = background.copy()
            for n in reversed(names):
                keep = cover[n] & (rng.random(cover[n].shape) < alpha)
                img = np.where(keep[..., None], layers[n], img)
            out += img / samples
        return out

    print(f"  Lantern as drawn (blended, transparent shadows): FLIP {mean_flip(full.rgba, ref):.4f}")
    print(f"  composed from layers, blended:              FLIP {mean_flip(blended, ref):.4f}")
    for spp in (1, 4, 16):
        print(f"  composed from layers, stochastic {spp:>2} spp:     "
              f"FLIP {mean_flip(stochastic(spp), ref):.4f}")


def shadows():
    print("\n3. transparent shadows: light through one / two layers of opacity 0.5 "
          "(exact 0.5 / 0.25), pixel noise (std) in the one-layer region")
    for preset in ("low", "medium", "high", "ultra"):
        r = render_stage(T.shadow_layers(), RenderSettings(width=96, height=96, preset=preset,
                                                           fxaa=False))
        lit = T.floor_region(r.rgba, (2.3, 2.9), (-1.9, -1.3))[0]
        one = T.floor_region(r.rgba, (1.2, 1.8), (-1.8, -1.2))[0] / lit
        two = T.floor_region(r.rgba, (1.2, 1.8), (-0.8, -0.2))[0] / lit
        h, w = r.rgba.shape[:2]
        c0, c1 = int((1.2 + 0.1) / 3.2 * w), int((1.8 + 0.1) / 3.2 * w)
        r0, r1 = int((1.1 + 1.2) / 3.2 * h), int((1.1 + 1.8) / 3.2 * h)
        noise = r.rgba[r0:r1, c0:c1, 0].std() / lit
        print(f"  {preset:<7} one {one:.3f}  two {two:.3f}  noise {noise:.3f}")


def area():
    print("\n4. area-light penumbrae vs Cycles (medium, no FXAA: point-sampled references)")
    print(f"  {'scene':<6}{'FLIP':>8}{'ratio':>8}{'shadowed ms':>13}{'unshadowed ms':>15}{'x':>6}")
    for name in penumbra_scenes.SCENES:
        scene = penumbra_scenes.build(name)
        settings = RenderSettings(width=320, height=180, frame=scene.frame_current, fxaa=False)
        small = RenderSettings(width=penumbra_scenes.SIZE[0], height=penumbra_scenes.SIZE[1],
                               frame=scene.frame_current, fxaa=False)
        stages = []
        for shadow in (True, False):
            for light in bpy.data.lights:
                light.use_shadow = shadow
            stages.append(stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())[0])
        cycles = read_exr(str(TESTS / "references" / "penumbra" / f"{name}.exr"))
        img = render_stage(stages[0], small)
        unshadowed = render_stage(stages[1], small)
        _, ratio = penumbra_scenes.penumbra(img.rgba, cycles, unshadowed.rgba)
        sessions = [Session(s, settings) for s in stages]
        times = [[], []]
        for s in sessions:
            s.render()
        for _ in range(5):
            for k, s in enumerate(sessions):
                times[k].append(s.render().gpu_timings["lights"])
        for s in sessions:
            s.close()
        a, b = (1000 * float(np.median(t)) for t in times)
        print(f"  {name:<6}{mean_flip(img.rgba, cycles):>8.4f}{ratio:>8.3f}{a:>13.1f}{b:>15.1f}"
              f"{a / b:>6.1f}")


def cost():
    print("\n5. transparency pass cost, three planes, 320 x 180 (medium)")
    eye, up = (3.0, 2.0, 7.0), (0.0, 0.0, 1.0)
    settings = RenderSettings(width=320, height=180)
    sessions = {"blended": Session(T.planes(eye, up), settings),
                "opaque": Session(T.planes(eye, up, alpha=1.0), settings)}
    totals = {k: [] for k in sessions}
    passes = []
    for s in sessions.values():
        s.render()
    for _ in range(7):
        for k, s in sessions.items():
            r = s.render()
            totals[k].append(r.timings["total"])
            if k == "blended":
                passes.append(r.gpu_timings["transparency"])
    for s in sessions.values():
        s.close()
    b, o = (1000 * float(np.median(totals[k])) for k in ("blended", "opaque"))
    print(f"  blended {b:.1f} ms (transparency pass {1000 * float(np.median(passes)):.1f} ms), "
          f"opaque {o:.1f} ms: {b / o:.2f}x")


if __name__ == "__main__":
    print(f"transparency and area shadows ({time.strftime('%Y-%m-%d')}, llvmpipe)")
    looks()
    hashed()
    shadows()
    area()
    cost()
