"""How many frames a render task holds, from what the first chunks measured.

A worker's first chunk is cold: it reads the stage, uploads it and compiles shaders
(`cold`, seconds). Later frames on that worker are warm renders (`warm`), since the
worker keeps its Session (sessions.py). Every task also costs a round trip to the
worker (`overhead`: the time the client waited minus the time the worker worked).

- The first wave is one FIRST-frame chunk per worker: every worker pays its cold cost at
  once, in parallel, the first frames arrive after one cold render, and each first
  chunk measures cold and warm.
- After it, a chunk is long enough that the round trip is at most OVERHEAD_SHARE of its
  warm renders: n >= overhead / (OVERHEAD_SHARE * warm).
- And short enough that work stays balanced and a lost worker costs little: at most
  the remaining frames over BALANCE chunks per worker, and at most what a worker
  renders in MAX_CHUNK_SECONDS.
- A worker that has not loaded the stage pays `cold` on its first chunk whatever its
  size; when `cold` is large against the frames left per worker
  (cold > frames_left * warm / workers), spreading the rest wider cannot pay, so the rest
  goes in chunks of the balance bound (fewer, longer tasks).
"""
from __future__ import annotations

import math

FIRST = 2                  # frames in a worker's first chunk: one cold, one warm render
OVERHEAD_SHARE = 0.05      # per-task round trip, as a share of the chunk's warm renders
BALANCE = 3                # chunks per worker, at least, for what is left
MAX_CHUNK_SECONDS = 30.0   # the most a retry after a lost worker redoes


def first_wave(frames, workers):
    """The first chunks: FIRST frames for each of `workers`."""
    take = min(len(frames), FIRST * max(1, workers))
    return [frames[i:i + FIRST] for i in range(0, take, FIRST)]


def chunk_size(cold, warm, overhead, left, workers):
    """Frames per task for the `left` frames, from the measured costs (seconds)."""
    if left <= 0:
        return 1
    workers = max(1, workers)
    warm = max(warm, 1e-4)
    balanced = max(1, math.ceil(left / (BALANCE * workers)))
    if cold > left * warm / workers:
        return balanced
    amortised = math.ceil(max(overhead, 0.0) / (OVERHEAD_SHARE * warm))
    longest = max(1, int(MAX_CHUNK_SECONDS / warm))
    return max(1, min(amortised, balanced, longest))


def split(frames, size):
    return [frames[i:i + size] for i in range(0, len(frames), size)]
