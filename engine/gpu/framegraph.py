"""Passes that declare what they read and write, run in order over a blackboard (a
small version of Filament's frame graph).

Each pass names the entries it reads and writes. Entries listed in TARGETS are render
targets: the graph takes them from the session's pool (by size and format) before the
first pass that writes them and gives them back after the last pass that uses them, so
a warm frame allocates nothing. Other entries are whatever a pass hands on (this
frame's view, the shadow maps, the read-back image). A pass the frame does not need
(`needed` is false) does not run and allocates nothing; an entry a pass writes only
for some frames (`writes_optional`, `wanted`) is allocated only for them, and the passes
after it read it as `optional`. The order is checked once:
every entry a pass reads is written by a pass before it.

Render passes (AOVs, core/passes.py) are targets too: a pass lists in `aovs` the
render passes it can write, each as (target, first channel). A frame asks for some
(`Frame.aovs`); a pass writes an AOV target only when one of its AOVs is asked for
(and a pass that only writes AOVs runs only then), so an AOV nobody asked for costs
nothing. The graph keeps the asked-for AOV targets to the end of the frame and reads
them back as float32 arrays, row 0 = top, into `board["aovs"]`. Lighting passes add
theirs the same way: a target here, an entry in their `aovs`.

Each pass is timed twice: `timings` holds the CPU time spent issuing it, and GPU
timestamps around it give its GPU time (engine/gpu/timers.py, `gpu_times`). Nothing
waits between passes; the stamps are read once the frame's pixels are in host memory,
so reading them never stalls the pipeline."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ...core.passes import MATTE_LEVELS, PASSES
from ..settings import RenderSettings
from .readback import SLOTS, ReadbackRequest
from .stencil import entry_points
from .timers import PassTimer

# Render targets by name: their pool format, at the frame's size.
TARGETS = {
    "g_base": "rgba16f",       # base colour, alpha
    "g_normal": "rgba16f",     # world normal, clearcoat roughness
    "g_mat": "rgba16f",        # metallic, roughness, dielectric F0, clearcoat
    "g_emit": "rgba16f",       # emission; alpha 1 where the base colour takes the AO
    "g_depth": "depth",         # 32-bit float, reversed (engine/view.py)
    "edge_depth": "depth_ms4",  # g_depth at four places a texel (passes/gbuffer.py)
    "g_smooth": "rgba16f",     # world normal before the normal map (bump map correction)
    "g_sheen": "rgba16f",      # sheen colour; roughness + 2 x mode (passes/gbuffer.py)
    "ao": "rgba32f",           # ambient occlusion of the dome's light, bent normal (passes/ao.py)
    "hdr": "rgba32f",          # light accumulation: float32, 1e-38..3e38 (a 1e-6 W and a
                               # 1e6 W light alike; float16 underflowed and overflowed)
    "depth_stencil": "depth_stencil",  # scene depth copy and light-volume marks
    # The resolved image, in the format it is read back in: a read is then a copy. A
    # driver converting float32 to half floats as it reads may do it on the CPU (NVIDIA
    # 580: 68 ms at 1920x1080, against 2.2 ms for the float32 read; docs/gpu.md).
    "output": "rgba32f",
    "output_half": "rgba16f",
    # Render passes (AOVs), only when asked for (core/passes.py).
    "g_index": "rgba32f",      # object and material pass indices and ids (the G-buffer pass)
    "aov_depth": "r32f",       # view-axis distance (the AOV pass)
    "aov_normal": "rgba32f",   # world normal
    "aov_emit": "rgba32f",     # emission
    "aov_ao": "rgba32f",       # ambient occlusion (the AO pass)
    "aov_diffuse": "rgba32f",  # diffuse light (the ambient and light passes)
    "aov_glossy": "rgba32f",   # specular and coat light (the same)
    "aov_diffuse_indirect": "rgba32f",  # the field's diffuse light (the ambient pass)
    "aov_glossy_indirect": "rgba32f",   # the glossy bounce (the reflection pass)
    "aov_env": "rgba32f",      # the dome seen directly (the ambient pass)
    "aov_shadow": "rgba32f",   # light reaching surfaces: with, without shadows (lights)
    # Cryptomatte's levels, two ranks each, at the image's size (passes/cryptomatte.py).
    **{f"crypto_{matte}{level}": "rgba32f" for matte in ("object", "material", "asset")
       for level in range(MATTE_LEVELS)},
}


@dataclass
class Frame:
    """One render: what the passes share that is not a target."""
    scene: object
    changes: object
    size: tuple
    preset: object
    transparent: bool = False
    aovs: frozenset = frozenset()  # render passes asked for (core/passes.py names)
    aov_targets: dict = field(default_factory=dict)  # each asked-for one's (target,
                                                     # first channel), set by the graph
    camera: object = None          # None: the view pass frames the default view
    options: RenderSettings = field(default_factory=RenderSettings)  # shading and post
    # Anti-aliasing (passes/antialias.py): drawn `supersample` times wider and taller
    # than `output_size`, the image's; `size` is what the passes draw at now.
    supersample: int = 1
    output_size: tuple | None = None
    readback: ReadbackRequest = field(default_factory=ReadbackRequest)
    # The forms this frame's passes take (resolved from the settings and the context
    # by the renderer): compute shaders or their raster forms; clustered lighting or
    # light volumes.
    compute: bool = False
    lighting: str = "volumes"
    slot: object = None            # the read-back slot the resolve pass used
    stamps: object = None          # the GPU timestamps around its passes (timers.py)
    board: dict | None = None      # what the graph handed on, until the frame is finished

    @property
    def glass_refracts(self) -> bool:
        """Whether light goes through glass this frame. Cycles' paths stop at glass
        without bounces (Max Bounces 0): glass then shows its reflections alone, is
        drawn in the G-buffer (it hides and occludes what is behind it) and shadows
        fully (passes/glass.py)."""
        return self.options.bounces_for(self.scene).total > 0

    @property
    def fxaa(self) -> bool:
        o = self.options.fxaa
        return bool(self.preset.fxaa if o is None else o)
    stats: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)

    def count(self, name, n=1):
        self.stats[name] = self.stats.get(name, 0) + n


class Pass:
    name = ""
    reads: tuple = ()
    optional: tuple = ()   # entries read when a pass before wrote them this frame
    writes: tuple = ()
    writes_optional: tuple = ()  # entries written only in the frames that need them
    aovs: dict = {}     # render pass name -> (target, first channel) this pass can write
    # Hands its writes on at the frame's output size, at which the passes after it draw
    # (supersampling's reduction sets frame.size to it).
    resizes: bool = False

    def needed(self, frame: Frame) -> bool:
        return True

    def wanted(self, frame: Frame) -> tuple:
        """The entries of `writes_optional` this frame needs."""
        return ()

    def aov_targets(self, frame: Frame) -> tuple:
        """The AOV targets this frame asks this pass to write."""
        return tuple(dict.fromkeys(t for name, (t, _) in self.aovs.items()
                                   if name in frame.aovs))

    def execute(self, frame: Frame, board: dict) -> None:
        raise NotImplementedError

    def release(self) -> None:
        """Releases what the pass keeps between frames (the graph's targets are not
        its own)."""


class FrameGraph:
    def __init__(self, ctx, pool, passes, proc):
        self.ctx, self.pool, self.passes = ctx, pool, list(passes)
        self.timer = PassTimer(proc, SLOTS)     # a queued frame's stamps are read late
        self._flush = entry_points(proc, {"glFlush": (None,)})["glFlush"]
        written = set()
        self.producers = {}     # render pass name -> the passes that can write it, in order
        for p in self.passes:
            missing = [r for r in p.reads + p.optional if r not in written]
            if missing:
                raise ValueError(f"pass {p.name} reads {missing} before any pass writes them")
            written |= set(p.writes) | set(p.writes_optional)
            for aov, (target, _) in p.aovs.items():
                if target not in TARGETS:
                    raise ValueError(f"pass {p.name} writes {aov} into {target}, not a target")
                others = self.producers.setdefault(aov, [])
                if others and others[0].aovs[aov] != p.aovs[aov]:
                    raise ValueError(f"pass {p.name} writes {aov} where {others[0].name} "
                                     "does not")
                others.append(p)

    def _plan(self, frame: Frame):
        """(the passes that run, what each writes, {target: index of the last pass
        using it}; the AOV targets, kept to the end, have none)."""
        unknown = sorted(set(frame.aovs) - set(self.producers))
        if unknown:
            raise ValueError(f"no pass writes the render passes {unknown}")
        live = [p for p in self.passes if p.needed(frame)]
        # An asked-for render pass needs a pass that runs and writes it (the lighting
        # ones are started by the ambient pass and added to by the light pass of the
        # frame's form, into the same target).
        for aov in frame.aovs:
            if not any(p in live for p in self.producers[aov]):
                raise RuntimeError(f"the pass writing {aov} "
                                   f"({self.producers[aov][-1].name}) did not run")
        writes = {p: p.writes + p.wanted(frame) + p.aov_targets(frame) for p in live}
        kept = {t for p in live for t in p.aov_targets(frame)}   # read back at the end
        last_use = {}
        for i, p in enumerate(live):
            for name in p.reads + p.optional + writes[p]:
                if name in TARGETS and name not in kept:
                    last_use[name] = i
        return live, writes, last_use

    def plan(self, frame: Frame):
        """What `run` will do for this frame, worked out once: pass it to `held` and
        `run`."""
        return self._plan(frame)

    @staticmethod
    def held(frame: Frame, plan) -> dict:
        """{(size, format): the most targets of it the frame holds at once}: what `run`
        takes from the pool (its targets' memory, engine/gpu/budget.py)."""
        live, writes, last_use = plan
        size, held, most = frame.size, {}, {}
        for i, p in enumerate(live):
            if p.resizes:
                size = frame.output_size or size
            for name in writes[p]:
                if name in TARGETS and (name not in held or p.resizes):
                    key = held[name] = (size, TARGETS[name])
                    most[key] = max(most.get(key, 0), list(held.values()).count(key))
            for name in [n for n, last in last_use.items() if last == i and n in held]:
                del held[name]
        return most

    def run(self, frame: Frame, plan=None) -> dict:
        board = {}
        live, writes, last_use = plan or self._plan(frame)
        frame.stats["passes"] = [p.name for p in live]
        frame.aov_targets = {aov: self.producers[aov][0].aovs[aov] for aov in frame.aovs}
        stamps = frame.stamps = self.timer.begin()
        try:
            for i, p in enumerate(live):
                for name in writes[p]:
                    if name in TARGETS and name not in board:
                        board[name] = self.pool.acquire(frame.size, TARGETS[name])
                absent = [r for r in p.reads if r in TARGETS and r not in board]
                if absent:
                    raise RuntimeError(f"pass {p.name} reads {absent}, which no pass wrote")
                t0 = time.perf_counter()
                p.execute(frame, board)
                stamps.stamp(p.name)
                # Each pass goes to the GPU as it ends. NVIDIA's driver held a frame's
                # commands until the read-back asked for its pixels, so the GPU started
                # only once Python had issued the whole frame (docs/gpu.md).
                self._flush()
                frame.timings[p.name] = frame.timings.get(p.name, 0.0) + time.perf_counter() - t0
                for name in [n for n, last in last_use.items() if last == i and n in board]:
                    self.pool.release(board.pop(name))
            board["aovs"] = {aov: self._read_back(board, *frame.aov_targets[aov], aov)
                             for aov in sorted(frame.aovs)}
        finally:
            for name in [n for n in board if n in TARGETS]:
                self.pool.release(board.pop(name))
            self.pool.trim()
        for p in self.passes:
            frame.timings.setdefault(p.name, 0.0)
        return board

    @staticmethod
    def gpu_times(frame: Frame) -> dict:
        """{pass: GPU seconds} of a frame whose pixels are in host memory (its stamps
        are done then, so this does not wait)."""
        return frame.stamps.seconds()

    @staticmethod
    def _read_back(board, target, first, aov):
        tex = board[target]
        w, h = tex.size
        data = np.frombuffer(tex.read(), np.float32).reshape(h, w, tex.components)
        channels = PASSES[aov].channels
        return np.ascontiguousarray(data[::-1, :, first:first + channels])  # GL rows run bottom-up

    def release(self):
        self.timer.release()
        for p in self.passes:
            p.release()
