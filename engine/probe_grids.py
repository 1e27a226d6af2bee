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


def grid(lo, hi, along_longest: int):
    """(first probe, spacing, counts) of a grid of cell-centred probes over the box."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    size = hi - lo
    spacing = max(float(size.max()), 1e-6) / along_longest
    counts = np.maximum(np.ceil(size / spacing - 1e-6), 1).astype(int)
    step = np.where(size > 0, size / counts, spacing)
    return lo + (0.5 + NUDGE) * step, step, counts


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
        counts = np.where(short, np.maximum(np.ceil(size / spacing - 1e-6), 1),
                          along_longest).astype(int)
        step = np.where(short & (size > 0), size / counts, spacing)
        box_lo = lo + start * step
        first = box_lo + (0.5 + NUDGE) * step
        last = first + (counts - 1) * step
        region_lo = np.where(short | (start <= 0), -UNBOUNDED, first)
        region_hi = np.where(short | (box_lo + counts * step >= hi - 1e-6 * size), UNBOUNDED,
                             last)
        out.append(Grid(first, step, counts, region_lo, region_hi))
    return out + [whole]
