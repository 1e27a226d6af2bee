"""The engine host's warm-up: before Blender asks for a first frame, render a small
stage like Blender's default scene (a cube with a material, a shadowed point light, a
grey world, a camera) once per preset a first frame is likely drawn with, then, at the
first preset, a stage with the features a first frame commonly needs besides (every
light kind, an image texture, skinning), without and with a normal map (which
changes every lighting program). So the programs are made (loaded from the program
cache, engine/gpu/program_binaries.py, when it has them) and the driver has built its
draw code for them (llvmpipe does that on a program's first draw). A scene that
needs other variants makes only those later."""
from __future__ import annotations

import tempfile
import time

import numpy as np

SIZE = 16


def warm(presets, stop=lambda: False) -> float:
    """Renders the default stage once per preset, in order, then the feature stage at
    the first preset without and with its normal map: the first render always, the
    others until stop() says a request waits (it then makes what it needs itself);
    returns the seconds it took."""
    from ..bounces import Bounces
    from ..image_io import write_image
    from ..session import Session
    from ..settings import RenderSettings
    from ..usd.default_scene import FEATURE_NORMAL_MAPPED, default_scene, feature_scene
    start = time.perf_counter()
    order = list(dict.fromkeys(presets))
    # Lit as a new Blender scene asks (Cycles' default bounces, which the exporter
    # writes): the bounce's programs too.
    lit = Bounces()
    with Session(default_scene(), RenderSettings(width=SIZE, height=SIZE, preset=order[0],
                                                 bounces=lit)) as session:
        for i, preset in enumerate(order):
            if i and stop():
                return time.perf_counter() - start
            session.configure(preset=preset)
            session.render()
    with tempfile.TemporaryDirectory(prefix="lantern-warmup-") as folder:
        texture = f"{folder}/texture.png"
        write_image(texture, np.full((4, 4, 4), 0.5, np.float32))
        stage = feature_scene(texture)
        normal_mapped = stage.GetPrimAtPath(FEATURE_NORMAL_MAPPED)
        with Session(stage, RenderSettings(width=SIZE, height=SIZE, preset=order[0],
                                           bounces=lit)) as session:
            for active in (False, True):
                if stop():
                    break
                normal_mapped.SetActive(active)
                session.render()
    return time.perf_counter() - start
