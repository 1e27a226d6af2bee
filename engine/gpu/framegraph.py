"""Passes that declare what they read and write, run in order over a blackboard (a
small version of Filament's frame graph).

Each pass names the entries it reads and writes. Entries listed in TARGETS are render
targets: the graph takes them from the session's pool (by size and format) before the
first pass that writes them and gives them back after the last pass that uses them, so
a warm frame allocates nothing. Other entries are whatever a pass hands on (this
frame's view, the shadow maps, the read-back image). A pass the frame does not need
(`needed` is false) does not run and allocates nothing. The order is checked once:
every entry a pass reads is written by a pass before it."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

# Render targets by name: their pool format, at the frame's size.
TARGETS = {
    "g_base": "rgba16f",       # base colour, alpha
    "g_normal": "rgba16f",     # world normal
    "g_mat": "rgba16f",        # metallic, roughness, dielectric F0
    "g_emit": "rgba16f",       # emission
    "g_depth": "depth",
    "hdr": "rgba16f",          # light accumulation
    "depth_stencil": "depth_stencil",  # scene depth copy and light-volume marks
    "output": "rgba32f",
}


@dataclass
class Frame:
    """One render: what the passes share that is not a target."""
    scene: object
    changes: object
    size: tuple
    preset: object
    transparent: bool = False
    camera: object = None          # None: the view pass frames the default view
    stats: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)

    def count(self, name, n=1):
        self.stats[name] = self.stats.get(name, 0) + n


class Pass:
    name = ""
    reads: tuple = ()
    writes: tuple = ()

    def needed(self, frame: Frame) -> bool:
        return True

    def execute(self, frame: Frame, board: dict) -> None:
        raise NotImplementedError

    def release(self) -> None:
        """Releases what the pass keeps between frames (the graph's targets are not
        its own)."""


class FrameGraph:
    def __init__(self, ctx, pool, passes):
        self.ctx, self.pool, self.passes = ctx, pool, list(passes)
        written = set()
        for p in self.passes:
            missing = [r for r in p.reads if r not in written]
            if missing:
                raise ValueError(f"pass {p.name} reads {missing} before any pass writes them")
            written |= set(p.writes)

    def run(self, frame: Frame) -> dict:
        board = {}
        live = [p for p in self.passes if p.needed(frame)]
        last_use = {}
        for i, p in enumerate(live):
            for name in p.reads + p.writes:
                if name in TARGETS:
                    last_use[name] = i
        frame.stats["passes"] = [p.name for p in live]
        try:
            for i, p in enumerate(live):
                for name in p.writes:
                    if name in TARGETS and name not in board:
                        board[name] = self.pool.acquire(frame.size, TARGETS[name])
                absent = [r for r in p.reads if r in TARGETS and r not in board]
                if absent:
                    raise RuntimeError(f"pass {p.name} reads {absent}, which no pass wrote")
                t0 = time.perf_counter()
                p.execute(frame, board)
                self.ctx.finish()            # so each pass's time is its own
                frame.timings[p.name] = time.perf_counter() - t0
                for name in [n for n, last in last_use.items() if last == i]:
                    self.pool.release(board.pop(name))
        finally:
            for name in [n for n in board if n in TARGETS]:
                self.pool.release(board.pop(name))
            self.pool.trim()
        for p in self.passes:
            frame.timings.setdefault(p.name, 0.0)
        return board

    def release(self):
        for p in self.passes:
            p.release()
