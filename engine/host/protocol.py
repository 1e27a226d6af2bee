"""What the two processes of the engine host say to each other, and the shared
memory pixels travel in. Plain Python and numpy: both sides import this.

A message is (kind, fields) pickled (protocol 5: numpy arrays go in as one copy).
A frame in a slot is Combined RGBA float32, then each render pass asked for, in
order, all (H, W, C) float32 with row 0 at the bottom (Blender's order)."""
from __future__ import annotations

import contextlib
import os
import pickle
import sys
import threading

import numpy as np
from multiprocessing import shared_memory

# Blender -> host
EDIT, RENDER, SLOTS, RELEASE, FORGET, DROP, QUIT, WARM = (
    "edit", "render", "slots", "release", "forget", "drop", "quit", "warm")
# host -> Blender
READY, FRAME, ERROR, FATAL = "ready", "frame", "error", "fatal"

# What a progressive view shows while it moves: the low preset, at the resolution
# that its measured frame time allows within INTERACTIVE_BUDGET (about 30 frames a
# second; interactive_scale), drawn stretched; once no new request came for
# SETTLE_SECONDS after that frame, the scene's preset at full size. The first moving
# frame is drawn at INTERACTIVE_SCALE, to measure. A GPU that draws the full size in
# budget gets the full size; llvmpipe gets less.
INTERACTIVE_PRESET = "low"
INTERACTIVE_SCALE = 0.5
INTERACTIVE_BUDGET = 1 / 30          # seconds
INTERACTIVE_SCALES = (1.0, 0.75, 0.5, 0.375, 0.25)   # steps, so sizes do not jitter
INTERACTIVE_MIN_PIXELS = 320 * 180
SETTLE_SECONDS = 0.15
# How often the host asks whether the programs a viewport frame waits for are made.
PROGRAM_POLL_SECONDS = 0.05


def interactive_scale(last_scale: float | None, last_seconds: float | None,
                      budget: float = INTERACTIVE_BUDGET) -> float:
    """The scale of the next moving frame: the largest step whose pixels, at the cost
    per pixel the last moving frame measured, fit the budget (frame time grows with
    pixels on a fill-bound view; the smallest step when none fits)."""
    if last_scale is None or not last_seconds or last_seconds <= 0:
        return INTERACTIVE_SCALE
    per_full_frame = last_seconds / (last_scale * last_scale)
    for scale in INTERACTIVE_SCALES:
        if per_full_frame * scale * scale <= budget:
            return scale
    return INTERACTIVE_SCALES[-1]
SLOTS_PER_TARGET = 3         # one shown, one being written, one in flight


def dumps(kind: str, **fields) -> bytes:
    return pickle.dumps((kind, fields), protocol=5)


def loads(data: bytes):
    return pickle.loads(data)


def layout(width: int, height: int, passes) -> tuple:
    """([(name, channels, byte offset)], total bytes) of a frame: Combined, then the
    passes ((name, channels) pairs) in the order given."""
    out, offset = [], 0
    for name, channels in (("Combined", 4), *passes):
        out.append((name, int(channels), offset))
        offset += width * height * int(channels) * 4
    return out, offset


def view(block, width, height, channels, offset) -> np.ndarray:
    """A float32 (H, W, C) view of a slot's memory (no copy)."""
    return np.ndarray((height, width, channels), np.float32, block.buf, offset)


_tracking = threading.Lock()


@contextlib.contextmanager
def _untracked():
    """Shared memory that multiprocessing's resource tracker leaves alone: the
    tracker is one more process, which would outlive a disabled add-on, and Python
    3.11 registers even blocks it only attaches (3.13 has track=False). The side
    that creates a block unlinks it."""
    from multiprocessing import resource_tracker
    with _tracking:
        saved = resource_tracker.register, resource_tracker.unregister
        resource_tracker.register = resource_tracker.unregister = lambda *args: None
        try:
            yield
        finally:
            resource_tracker.register, resource_tracker.unregister = saved


def create_block(name: str, size: int) -> shared_memory.SharedMemory:
    if sys.version_info >= (3, 13):
        return shared_memory.SharedMemory(name, create=True, size=size, track=False)
    with _untracked():
        return shared_memory.SharedMemory(name, create=True, size=size)


def attach_block(name: str) -> shared_memory.SharedMemory:
    if sys.version_info >= (3, 13):
        return shared_memory.SharedMemory(name, track=False)
    with _untracked():
        return shared_memory.SharedMemory(name)


def release_block(block, unlink: bool):
    """Closes a block (and unlinks it, by its creator); views into it must be gone."""
    try:
        block.close()
    except BufferError:          # a numpy view still holds it: the mapping goes later
        pass
    if unlink and os.name != "nt":
        try:
            with _untracked():
                block.unlink()
        except FileNotFoundError:
            pass
