"""The Cryptomatte pass: object, material and asset mattes as the specification's
ranking filter makes them (core/cryptomatte.py; names: engine/cryptomatte.py).

The G-buffer pass writes each sample's ids (g_index: 1 + the object's id, the
material's Cryptomatte id) at the size it draws: one sample a pixel at low and
medium, 2x2 at high, 3x3 at ultra (passes/antialias.py). For each pixel this pass
counts, per id, the share of the pixel's own samples that see it, its coverage, and
ranks the ids by it: a box over the pixel's samples. So coverage is exact in steps of
the samples (0 or 1 at one sample, as EEVEE's at 1 sample; ninths at ultra), and a
pixel's ranks sum to the share of its samples that see any surface. Cycles and EEVEE
weight samples by their film filter instead, as the specification suggests (the
beauty's kernel): with Lantern's Blackman-Harris 1.5 px the coverage of an edge pixel
would differ from its own samples' share by up to 0.15 at corners (tests/
test_cryptomatte.py prints it), where a box is exact; the matte's edge is the sharper
by the filter's spread. Nothing drawn adds no id and no coverage. Blended surfaces (the
transparency pass) are not in the mattes, as in no other render pass.

One screen pass per matte asked for (shaders/cryptomatte.glsl, in either form:
engine/gpu/screen.py), writing its three RGBA32F levels (six ranks) at the image's
size; so the pass runs after the supersample pass, where the graph's size is the
image's.

reads: g_index (written by the G-buffer pass when a matte is asked for)
render passes: CryptoObject00-02, CryptoMaterial00-02, CryptoAsset00-02"""
from __future__ import annotations

import numpy as np

from ....core.cryptomatte import name_id
from ....core.passes import MATTE_LEVELS, MATTES
from ...cryptomatte import object_name
from ..framegraph import Pass
from ..programs import UNITS, set_uniform
from ..screen import run_screen, screen_program
from .antialias import MAX_TAPS

NAMES_W = 4096          # shaders/cryptomatte.glsl NAMES_W: texels per row of the name table
VARIANT = {"CryptoObject": "MATTE_OBJECT", "CryptoMaterial": "MATTE_MATERIAL",
           "CryptoAsset": "MATTE_ASSET"}


def filter_taps(k: int) -> tuple:
    """(offsets from the pixel's first sample, weights) along one axis of the samples
    a pixel's coverage counts: its own k, evenly."""
    return np.arange(k), np.full(k, 1.0 / k)


class CryptomattePass(Pass):
    name = "cryptomatte"
    reads = ("g_index",)
    aovs = {f"{matte}{level:02d}": (f"crypto_{matte[6:].lower()}{level}", 0)
            for matte in MATTES for level in range(MATTE_LEVELS)}

    def __init__(self, ctx, pool, programs, geometry, uploads):
        self.ctx, self.pool, self.programs = ctx, pool, programs
        self.geometry, self.uploads = geometry, uploads
        self._names = None         # the name table's texture
        self._texels = None        # what it holds

    def needed(self, frame):
        return any(name in frame.aovs for name in self.aovs)

    def execute(self, frame, board):
        ctx = self.ctx
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        self._update_names(frame.scene)
        board["g_index"].use(UNITS["crypto_ids"])
        self._names.use(UNITS["crypto_names"])
        offsets, weights = filter_taps(frame.supersample)
        taps = np.zeros((MAX_TAPS, 2), np.float32)
        taps[:len(offsets)] = np.stack([offsets, weights], -1)
        for matte, variant in VARIANT.items():
            levels = [f"{matte}{level:02d}" for level in range(MATTE_LEVELS)]
            if levels[0] not in frame.aovs:
                continue
            prog = screen_program(self.programs, "cryptomatte", [variant] + (
                ["ONE_SAMPLE"] if frame.supersample == 1 else []), frame.compute,
                outputs=MATTE_LEVELS)
            set_uniform(prog, "factor", frame.supersample)
            set_uniform(prog, "taps", len(offsets))
            set_uniform(prog, "tap", taps)
            run_screen(ctx, self.programs, self.pool, prog,
                       [board[self.aovs[n][0]] for n in levels], frame.compute)

    def _update_names(self, scene):
        """The table from object id to (object matte id, asset matte id), uploaded
        when it changed."""
        drawn = [(d.oid, d.n, d.path, scene.instances[d.path].asset)
                 for d in self.geometry.draws.values() if d.path in scene.instances]
        drawn += [(c.oid, 1, path, scene.points[path].asset)
                  for path, c in self.geometry.points.clouds.items() if path in scene.points]
        count = max((oid + n for oid, n, _, _ in drawn), default=1)
        rows = -(-count // NAMES_W)
        texels = np.zeros((rows * NAMES_W, 4), np.float32)
        for oid, n, path, asset in drawn:
            texels[oid:oid + n, 0] = name_id(object_name(path))
            texels[oid:oid + n, 1] = name_id(asset)
        texels = texels.reshape(rows, NAMES_W, 4)
        if self._texels is not None and self._texels.shape == texels.shape and \
                np.array_equal(self._texels, texels):
            return
        self._names = self.uploads.rewrite_float_texture(self._names, texels, kind="objects")
        self._texels = texels

    def release(self):
        if self._names is not None:
            self._names.release()
            self._names = None
            self._texels = None
