"""Clearcoat against Cycles: a sphere in a white furnace (clearcoat_scenes), coat
weights 0.25, 0.5 and 1, coat roughness 0.03, 0.1 and 0.5, over a dark and a bright
base, against the committed Cycles renders in references/clearcoat/ (made by
references/make_cycles_references.py clearcoat). The mean over the sphere's interior
within 2%."""
import functools
import pathlib

import numpy as np
import pytest

import clearcoat_scenes

REFERENCES = pathlib.Path(__file__).resolve().parent / "references" / "clearcoat"
BOUND = 0.02


@functools.lru_cache(maxsize=None)
def _stage(name):
    import bpy
    from lantern.exporters import stage_from_depsgraph
    clearcoat_scenes.build(name)
    stage, _ = stage_from_depsgraph(bpy.context.evaluated_depsgraph_get())
    return stage


def sphere_means(name, **settings):
    """(Lantern's mean, Cycles' mean) over the sphere's pixels."""
    from lantern.engine import RenderSettings, read_exr, render_stage
    from lantern.engine.bounces import DIRECT
    w, h = clearcoat_scenes.SIZE
    # The references are Cycles' with bounces 0 (references/make_cycles_references.py).
    result = render_stage(_stage(name), RenderSettings(width=w, height=h, bounces=DIRECT,
                                                       passes=frozenset(["Depth"]), **settings))
    # Cycles' pixel filter reaches 1.5 px: its silhouette pixels blend in the white
    # world, which would weigh a dark sphere's mean by its outline. The interior only.
    sphere = result.passes["Depth"][..., 0] < 1e9
    for _ in range(2):
        sphere &= np.roll(sphere, 1, 0) & np.roll(sphere, -1, 0) & \
            np.roll(sphere, 1, 1) & np.roll(sphere, -1, 1)
    assert sphere.sum() > 0.3 * w * h
    reference = read_exr(str(REFERENCES / f"{name}.exr"))[..., :3].astype(np.float64)
    return float(result.rgba[..., :3][sphere].mean()), float(reference[sphere].mean())


@pytest.mark.parametrize("name", sorted(clearcoat_scenes.CASES))
def test_clearcoat_in_a_furnace_against_cycles(name):
    ours, cycles = sphere_means(name)
    print(f"{name}: Lantern {ours:.4f}, Cycles {cycles:.4f}, {ours / cycles - 1:+.2%}")
    assert abs(ours / cycles - 1) <= BOUND
