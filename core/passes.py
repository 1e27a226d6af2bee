"""Render passes (AOVs), the one table: the engine computes them by these names
(`RenderSettings.passes`, `RenderResult.passes`) and the add-on registers them with
Blender under the same names, for the view-layer switch Blender already has.

Names, channels and channel ids are Blender's own (Cycles registers the same), so a
pass maps one to one onto a Blender render pass. `provided` says whether the engine
produces the pass today; the add-on registers only those. A lighting pass becomes
available by writing its frame-graph target in the pass that computes it (see
engine/gpu/framegraph.py, `Pass.aovs`) and setting `provided` here.

Values, as Blender's (docs/stage_contract.md, "Render passes"):
  Depth    distance from the camera plane along the view axis, in scene units;
           1e10 where nothing is drawn (Cycles' background depth)
  Normal   world-space shading normal (normal maps applied, facing the viewer); 0 on
           the background
  Emit     emitted radiance; 0 on the background
  IndexOB  the object's pass index (Blender's Object > Relations > Pass Index,
           `lantern:passIndex` on the object prim); 0 where unset and on the background
  IndexMA  the material's pass index (Material > Settings > Pass Index,
           `lantern:passIndex` on the Material prim); 0 likewise
"""
from __future__ import annotations

from dataclasses import dataclass

BACKGROUND_DEPTH = 1e10


@dataclass(frozen=True)
class RenderPass:
    name: str          # Blender's pass name
    channels: int
    chan_id: str       # Blender's channel letters
    kind: str          # Blender's pass type: VALUE, VECTOR or COLOR
    view_layer: str    # the ViewLayer property that asks for it
    provided: bool     # the engine computes it today


PASSES = {p.name: p for p in (
    RenderPass("Depth", 1, "Z", "VALUE", "use_pass_z", True),
    RenderPass("Normal", 3, "XYZ", "VECTOR", "use_pass_normal", True),
    RenderPass("Emit", 3, "RGB", "COLOR", "use_pass_emit", True),
    RenderPass("IndexOB", 1, "X", "VALUE", "use_pass_object_index", True),
    RenderPass("IndexMA", 1, "X", "VALUE", "use_pass_material_index", True),
    # Lighting passes: written by the lighting passes once they compute them.
    RenderPass("AO", 3, "RGB", "COLOR", "use_pass_ambient_occlusion", False),
    RenderPass("Shadow", 3, "RGB", "COLOR", "use_pass_shadow", False),
    RenderPass("DiffDir", 3, "RGB", "COLOR", "use_pass_diffuse_direct", False),
    RenderPass("GlossDir", 3, "RGB", "COLOR", "use_pass_glossy_direct", False),
    RenderPass("Env", 3, "RGB", "COLOR", "use_pass_environment", False),
)}

COMBINED = "Combined"   # always rendered: RenderResult.rgba


def provided() -> list:
    """The passes the engine computes today, in table order."""
    return [p for p in PASSES.values() if p.provided]


def check(names) -> frozenset:
    """The requested pass names, checked: Combined is always there and is dropped
    here; an unknown or not-yet-provided name is a ValueError naming it."""
    out = set()
    for name in names:
        if name == COMBINED:
            continue
        p = PASSES.get(name)
        if p is None:
            raise ValueError(f"unknown render pass {name!r}; known passes: "
                             f"{', '.join([COMBINED] + list(PASSES))}")
        if not p.provided:
            raise ValueError(f"render pass {name!r} is not computed by the engine yet")
        out.add(name)
    return frozenset(out)
