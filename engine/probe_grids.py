"""Where the irradiance field's probes lie (engine/gpu/passes/irradiance.py): one grid
over the traced bounds, or, where the bounds are large, camera-centred cascades.

The rule: the finest cascade spans NEAR metres about the camera (a room) at the preset's
density (its probes along the bounds' longest side, along NEAR instead). One grid over
the bounds is that density's spacing times the longest side / NEAR: while that is at
most CASCADE_AFTER (a single grid at most 4 times coarser than the near one) the field
is one grid, as before. Beyond, nested grids each twice the previous one's side with
the same probes along it (fewer along an axis the bounds are shorter in), centred on
the place AHEAD of the camera on a STRIDE lattice and kept inside the bounds, each on its own
cells counted from the bounds' corner; the last is the one grid over the bounds. A
Grid's region is where it is whole (its probes' box; unbounded on a side that reaches
the bounds' edge): a point reads the finest grid whose region holds it
(shaders/irradiance_field.glsl)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

NEAR = 8.0                   # metres: the finest cascade's side
CASCADE_AFTER = 4.0          # one grid while the bounds' longest side is at most 4 NEARs
STRIDE = NEAR / 4            # the cascades follow the camera by steps of this
AHEAD = NEAR / 4             # their centre lies this far ahead of the camera
GRIDS = 8                    # at most (shaders/irradiance_field.glsl FIELD_GRIDS)
UNBOUNDED = 1.0e30
# Probes sit off their cells' centres by this share of the spacing: walls often lie on
# the centres' planes (a room as wide as its bounds, split in even cells), and a probe
# on a wall sees both sides (its rays start in the wall's plane). Off it, the probe sees
# the wall and is moved from it (shaders/irradiance_blend.comp), on whichever side.
NUDGE = np.array([0.0371, 0.0253, 0.0419])
# The outermost probes lie this share of the spacing inside the bounds' faces: where the
# bounds are a room's walls, floor and ceiling (the closed box, a room's bounds), those
# probes see what the surfaces there see. Cell-centred probes, half a spacing in, left a
# floor lit by probes half a spacing above it, which miss the walls' lit lower parts
# (the emissive panel's floor got half its bounce) and the dim corners (the box's ceiling
# by the back wall 30% bright). Over the fifth of a spacing within which a probe is moved
# from a surface (shaders/irradiance_blend.comp), so a box's probes stay where they are.
# A cascade takes it along the axes it spans whole (a ground's height: its floor and
# roof); elsewhere its faces are no surface's, and it keeps its cells' centres.
INSET = 0.25


@dataclass(frozen=True)
class Grid:
    first: np.ndarray        # probe (0, 0, 0)'s place
    step: np.ndarray         # spacing along each axis
    counts: np.ndarray       # probes along each axis
    region_lo: np.ndarray    # where it is whole
    region_hi: np.ndarray

    @property
    def probes(self) -> int:
        return int(np.prod(self.counts))


def span(size, spacing):
    """(spacing, counts, first probe as a share of the spacing) along each axis of a box
    of `size` whose probes lie about `spacing` apart, the outermost INSET of a spacing
    inside its faces (a flat side: one layer, half a spacing off it)."""
    cells = np.maximum(np.ceil(size / spacing - 2 * INSET - 1e-6), 1).astype(int)
    flat = size <= 0
    step = np.where(flat, spacing, size / (cells + 2 * INSET))
    return step, np.where(flat, 1, cells + 1), np.where(flat, 0.5, INSET)


def grid(lo, hi, along_longest: int):
    """(first probe, spacing, counts) of a grid of probes over the box, `along_longest`
    of them along its longest side (span's)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    size = hi - lo
    spacing = max(float(size.max()), 1e-6) / (max(along_longest, 2) - 1 + 2 * INSET)
    step, counts, share = span(size, spacing)
    return lo + (share + NUDGE) * step, step, counts


def cascaded(lo, hi) -> bool:
    """Whether the box gets cascades (the rule above)."""
    size = np.asarray(hi, np.float64) - np.asarray(lo, np.float64)
    return float(size.max()) > CASCADE_AFTER * NEAR


def placement(lo, hi, eye, forward):
    """The place the cascades are centred on (None: one grid): AHEAD of the camera along
    its view (what it sees lies ahead: a camera in a room's corner looks across it), on
    the STRIDE lattice and inside the box. The cascades move when it does."""
    if not cascaded(lo, hi):
        return None
    ahead = np.asarray(eye, np.float64) + AHEAD * np.asarray(forward, np.float64)
    at = np.clip(np.round(ahead / STRIDE) * STRIDE, lo, hi)
    return tuple(float(x) for x in at)


def grids(lo, hi, along_longest: int, centre=None) -> list:
    """The field's Grids, finest first: one over the box when `centre` is None, else the
    cascades about `centre` (placement's)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    free = np.full(3, UNBOUNDED)
    whole = Grid(*grid(lo, hi, along_longest), -free, free)
    if centre is None:
        return [whole]
    size, centre = hi - lo, np.asarray(centre, np.float64)
    # Twice the side each, the last over the bounds (more than GRIDS: finer ones dropped).
    sides = []
    side = NEAR
    while side < size.max():
        sides.append(side)
        side *= 2.0
    out = []
    for side in sides[-(GRIDS - 1):]:
        spacing = side / along_longest
        cells = np.floor(size / spacing + 1e-6)
        short = cells <= along_longest            # axes the grid spans whole
        start = np.floor((centre - 0.5 * side - lo) / spacing + 0.5)
        start = np.where(short, 0.0, np.clip(start, 0.0, cells - along_longest))
        whole_step, whole_counts, whole_share = span(size, spacing)
        counts = np.where(short, whole_counts, along_longest).astype(int)
        step = np.where(short, whole_step, spacing)
        box_lo = lo + start * step
        first = box_lo + (np.where(short, whole_share, 0.5) + NUDGE) * step
        last = first + (counts - 1) * step
        region_lo = np.where(short | (start <= 0), -UNBOUNDED, first)
        region_hi = np.where(short | (box_lo + counts * step >= hi - 1e-6 * size), UNBOUNDED,
                             last)
        out.append(Grid(first, step, counts, region_lo, region_hi))
    return out + [whole]
