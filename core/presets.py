"""Quality presets, the one table: the add-on's Quality menu lists them and the engine
renders with their values.

shadow_size: texels per shadow tile side (a cube face, a spot map, one sun cascade;
a light's lantern:shadowResolution wins). pcf_taps / blocker_taps: PCSS filter and
blocker-search samples. cascades: sun cascades. anisotropy: texture filtering.
disk_sides: the polygon a disk light is shaded as. ico_level: subdivisions of the
sphere drawn as a point light's volume."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Preset:
    name: str
    label: str
    description: str
    anisotropy: float
    disk_sides: int
    ico_level: int
    shadow_size: int
    pcf_taps: int
    blocker_taps: int
    cascades: int


PRESETS = {p.name: p for p in (
    Preset("low", "Low", "Fastest: smallest shadow maps and fewest filter taps",
           1.0, 16, 1, 512, 8, 8, 2),
    Preset("medium", "Medium", "Balanced quality and speed",
           4.0, 32, 1, 1024, 16, 12, 3),
    Preset("high", "High", "Larger shadow maps and softer filtering",
           8.0, 32, 2, 2048, 32, 16, 4),
    Preset("ultra", "Ultra", "Closest to Cycles, slowest",
           16.0, 32, 2, 4096, 64, 32, 4),
)}
DEFAULT = "medium"


def preset(name: str) -> Preset:
    """The named preset; an unknown name is a ValueError listing the valid ones."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; valid presets: {', '.join(PRESETS)}")
    return PRESETS[name]
