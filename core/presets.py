"""Quality presets, the one table: the add-on's Quality menu lists them and the engine
renders with their values.

shadow_size: texels per shadow tile side (a cube face, a spot map, one sun cascade;
a light's lantern:shadowResolution wins). pcf_taps / blocker_taps: PCSS filter and
blocker-search samples. cascades: sun cascades. anisotropy: texture filtering.
disk_sides: the polygon a disk light is shaded as. ico_level: subdivisions of the
sphere drawn as a point light's volume. ao_slices / ao_steps: ambient occlusion's
horizon-search directions (rays) and depth samples per side (0 slices: no AO).
ao_block: the search runs once per ao_block x ao_block pixels of the image, which the
blur fills in depth-aware (occlusion varies over the AO distance, far wider than a
pixel: docs/rendering.md, "Presets").
near_block / near_steps: the same for the diffuse bounce's near-field search
(engine/gpu/passes/near_field.py, over ao_slices directions); medium takes 6 samples a
side to the AO's 8, at the same error against Cycles (docs/rendering.md, "Steady frame
with the bounce": coarser blocks broke a PointInstancer's parity with its instances).
supersample: the image is drawn this many times wider and taller and filtered down
with Cycles' pixel filter (anti-aliasing; 1: not). supersample_within: the most
sub-pixels a supersampled image may have (0: any): medium supersamples small stills
(previews, thumbnails, the comparison suite's), whose edges are much of what is seen,
at less than a 640x480 image's cost. edge_samples: a supersampled image's
geometric edges are placed by four depth samples a sub-pixel (multisampled depth), not by
the sub-pixels alone (engine/gpu/passes/antialias.py). fxaa: FXAA on images not
supersampled.
Cost and error of each preset against the Cycles references: docs/rendering.md, "Presets"."""
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
    ao_slices: int
    ao_steps: int
    ao_block: int
    near_block: int
    near_steps: int
    supersample: int
    supersample_within: int
    edge_samples: bool
    fxaa: bool


PRESETS = {p.name: p for p in (
    Preset("low", "Low", "Fastest: smallest shadow maps, fewest filter taps, light occlusion, FXAA",
           1.0, 16, 1, 512, 8, 8, 2, 2, 4, 2, 2, 4, 1, 0, False, True),
    Preset("medium", "Medium", "Balanced quality and speed: FXAA, and 2x2 supersampling of "
           "images up to 320x240 (F12 and command line)",
           4.0, 32, 1, 1024, 16, 12, 3, 3, 8, 2, 2, 6, 2, 640 * 480, False, True),
    Preset("high", "High", "Larger shadow maps, 2x2 supersampling (F12 and command line)",
           8.0, 32, 2, 2048, 16, 12, 4, 4, 12, 1, 1, 12, 2, 0, True, False),
    Preset("ultra", "Ultra", "Closest to Cycles, slowest: 3x3 supersampling",
           16.0, 32, 2, 4096, 32, 16, 4, 8, 16, 1, 1, 16, 3, 0, True, False),
)}
DEFAULT = "medium"


def preset(name: str) -> Preset:
    """The named preset; an unknown name is a ValueError listing the valid ones."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; valid presets: {', '.join(PRESETS)}")
    return PRESETS[name]
