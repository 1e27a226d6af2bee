"""RenderSettings: what a render is asked for (size, frame, preset, view, passes,
shading and post options), a plain record. The Session takes it, and every frame
carries it to the passes (engine/gpu/framegraph.py Frame.options)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.presets import DEFAULT as DEFAULT_PRESET
from .bounces import DIRECT, Bounces

# The image's formats in host memory (engine/gpu/readback.py maps them to GL's).
READBACK_FORMATS = ("float32", "half")


@dataclass
class RenderSettings:
    width: int | None = None     # None: /Render/Settings resolution if authored, else 640x360
    height: int | None = None
    frame: float | None = None   # None: the stage's startTimeCode if authored, else Default
    preset: str = DEFAULT_PRESET  # low | medium | high | ultra (core/presets.py)
    transparent: bool = False    # alpha = coverage instead of 1
    # An explicit view instead of the stage's camera (Blender's viewport): OpenGL
    # world-to-view and projection matrices, column-vector convention.
    view_matrix: np.ndarray | None = None
    projection_matrix: np.ndarray | None = None
    camera: str | None = None    # a camera prim; None: /Render/Settings', else the first
    cull_backfaces: bool = False  # cull back faces of every single-sided mesh
    # Render passes (AOVs) to compute besides Combined, by Blender's names
    # (core/passes.py): only these are computed and read back.
    passes: frozenset = frozenset()
    # Shading (docs/rendering.md). Ambient occlusion of the dome's light (the preset sets its
    # rays and steps); off: the dome lights every surface unoccluded.
    ambient_occlusion: bool = True
    # 8-bit sRGB textures: "encoded" filters the stored values and decodes after (as
    # Cycles does); "linear" decodes, then filters (as EEVEE and GL's sRGB formats do).
    srgb_filtering: str = "encoded"
    # Anti-aliasing: supersampling, the image drawn k times wider and taller and
    # filtered down with Cycles' pixel filter (None: the preset's; high and ultra
    # supersample, for F12 and the command line; an interactive viewport may ask for
    # 1), and FXAA on images not supersampled (None: the preset's).
    supersample: int | None = None
    fxaa: bool | None = None
    # The post chain, on the scene-linear image (engine/gpu/passes/post.py): exposure
    # in stops, a Gaussian blur of `blur` pixels (sigma), grayscale (Rec. 709
    # luminance), mirror "x", "y" or "xy". All off by default: inside Blender the image
    # stays as rendered and Blender's colour management applies.
    exposure: float = 0.0
    blur: float = 0.0
    grayscale: bool = False
    mirror: str = ""
    # The image's format in host memory: "float32" (F12, files, compare) or "half"
    # (a viewport: half the bytes to copy; within float16 rounding of float32).
    readback: str = "float32"
    # Subdivision surfaces on GL 4.3 and later: tessellated by the GPU from their limit
    # surface's patches, each patch edge cut into pieces of about this many pixels
    # (at most one level finer than the render level). 0, or GL 3.3 and 4.1: refined
    # on the CPU to the render level. Read when the session opens.
    tessellation_px: float = 4.0
    # A viewport's frames: a material whose network changed shape is drawn as it was
    # until a helper process has made its new program (engine/gpu/compiler.py), so
    # the edit never waits on a compile (stats: programs_pending). Off for final
    # images, which draw every material as it is.
    background_compile: bool = False
    # A viewport's frames: the irradiance field traces at most its preset's ray budget
    # a frame and converges over frames to the field a still makes, frames showing its
    # last complete update meanwhile (stats field_rays, field_pending). Off for final
    # images, which build it converged.
    progressive_field: bool = False
    # The diffuse bounce's last step gathered per pixel: rays from each block of pixels
    # shaded at their hits as the field's probes shade theirs (engine/gpu/passes/
    # near_field.py), in place of the field's coarse light. None: in final images, not in
    # a viewport's frames (progressive_field), which show the field with the screen's
    # near field.
    final_gather: bool | None = None
    # GL 4.3 and later run the passes that do not rasterise (lighting, ambient
    # occlusion, the dome, post, the supersample reduction, the render passes, the
    # resolve) and skinning as compute shaders, which every shader core of a GPU runs
    # (fragment and vertex work runs on a few of a datacenter GPU's). None: on a GPU
    # wherever the context allows, and not on a software rasteriser, which runs both
    # forms on the same CPU threads; False: their raster forms (full-screen fragment
    # passes, transform feedback), as GL 3.3 and 4.1 draw them. One GLSL body each.
    compute: bool | None = None
    # How lights are shaded: "clustered" (lights culled into screen tiles and depth
    # slices on the GPU, then one compute pass; needs compute) or "volumes" (a light
    # volume per light, the GL 3.3/4.1 path). None: clustered wherever GL 4.3 runs,
    # unless compute is False.
    lighting: str | None = None
    # Clustered lighting's error bound, as a fraction of each pixel's light: far lights
    # are shaded in groups where that stays within it (0: every light on its own, cut
    # where its volume ends, as the volumes do).
    light_error: float = 0.01
    # How often light bounces (Cycles' Light Paths). None: the stage's /Render/Settings,
    # else direct light only (a stage that names no bounces, as Storm draws it).
    bounces: Bounces | None = None

    def gathers(self) -> bool:
        """Whether a frame with an irradiance field gathers its last bounce per pixel."""
        return not self.progressive_field if self.final_gather is None else self.final_gather

    def bounces_for(self, scene) -> Bounces:
        """The bounces a render of `scene` takes: these settings', else the stage's,
        else none."""
        if self.bounces is not None:
            return self.bounces
        return scene.bounces if scene.bounces is not None else DIRECT

    def __post_init__(self):
        if self.supersample is not None and (int(self.supersample) != self.supersample
                                             or not 1 <= self.supersample <= 8):
            raise ValueError(f"supersample must be a whole number from 1 to 8, not "
                             f"{self.supersample!r}")
        if not (self.blur >= 0.0 and math.isfinite(self.blur)):
            raise ValueError(f"blur must be a finite sigma >= 0 (pixels), not {self.blur!r}")
        if not math.isfinite(self.exposure):
            raise ValueError(f"exposure must be finite, not {self.exposure!r}")
        if not (self.tessellation_px >= 0.0 and math.isfinite(self.tessellation_px)):
            raise ValueError(f"tessellation_px must be a finite length >= 0 (pixels), not "
                             f"{self.tessellation_px!r}")
        if self.mirror not in ("", "x", "y", "xy"):
            raise ValueError(f"mirror must be '', 'x', 'y' or 'xy', not {self.mirror!r}")
        if self.readback not in READBACK_FORMATS:
            raise ValueError(f"readback must be one of {', '.join(READBACK_FORMATS)}, not "
                             f"{self.readback!r}")
        if self.lighting not in (None, "clustered", "volumes"):
            raise ValueError(f"lighting must be 'clustered' or 'volumes', not {self.lighting!r}")
        if self.lighting == "clustered" and self.compute is False:
            raise ValueError("clustered lighting runs in compute: it needs compute not False")
        if not (0.0 <= self.light_error < 1.0):
            raise ValueError(f"light_error must be a fraction from 0 to below 1, not "
                             f"{self.light_error!r}")
        if self.bounces is not None and not isinstance(self.bounces, Bounces):
            raise ValueError(f"bounces must be a Bounces record, not {self.bounces!r}")
        if self.srgb_filtering not in ("encoded", "linear"):
            raise ValueError(f"srgb_filtering must be 'encoded' or 'linear', not "
                             f"{self.srgb_filtering!r}")
