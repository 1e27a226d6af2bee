"""Render passes (AOVs), the one table: the engine computes them by these names
(`RenderSettings.passes`, `RenderResult.passes`), the add-on registers them with
Blender for the view-layer switch Blender already has, the command line asks for them
by `option` (`--passes`) and writes them into multi-layer EXRs under `title`.

`name` is the engine's key and Blender's pass name up to 4.5 (IndexOB, DiffDir, ...);
`title` is the name Blender 5.0 gives the same pass (Object Index, Diffuse Direct,
...), which it writes into its multi-layer EXRs as `<view layer>.<title>.<channel>`;
channels and channel ids are Blender's own (Cycles registers the same), so a pass maps
one to one onto a Blender render pass. `provided` says whether the engine produces the
pass today; the add-on registers only those. A lighting pass becomes available by
writing its frame-graph target in the pass that computes it (see
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
  AO       the ambient occlusion of the dome's light, grey: 1 unoccluded, also on the
           background
  DiffDir  diffuse light leaving surfaces, albedo included (Cycles divides it out into
           DiffCol; Lantern has no colour passes): every light's, shadowed, and the
           dome's, occluded, where the frame has no irradiance field
  DiffInd  the diffuse bounce, albedo included: the irradiance field's light (the
           bounced light, and the dome and the emitters that are no lights, which
           reach surfaces through the field); 0 in a frame without a field
  GlossDir the same as DiffDir for the specular lobe and the clearcoat, and of the
           glossy bounce the dome met by a reflected ray that escapes (and the dome's
           reflection where a rough lobe has no field to read)
  GlossInd the rest of the glossy bounce: the lit frame a reflected ray meets, and
           the field read along the lobe; 0 in a frame without the glossy bounce
  Env      the world (dome) seen directly where nothing is drawn; 0 on surfaces
  Shadow   light reaching surfaces with shadows over without, summed over the lights
           (luminance, grey): 1 lit or unlit by any light, 0 in full shadow
  CryptoObject00.. (and Material, Asset) Cryptomatte: per rank, the id (a hashed prim
           path, core/cryptomatte.py) and coverage of the objects, materials or
           assets seen in the pixel, two ranks per RGBA layer, by coverage
           (engine/gpu/passes/cryptomatte.py)
  Without FXAA or post, Combined = DiffDir + DiffInd + GlossDir + GlossInd + Env + Emit
  (docs/passes.md "Direct and indirect light": the split against Cycles').
Transparent pixels: blended surfaces (docs/stage_contract.md, "Transparency") are in
Combined only; every pass above holds the opaque surface behind them, so with blended
surfaces in view Combined is no longer that sum there.
"""
from __future__ import annotations

from dataclasses import dataclass

BACKGROUND_DEPTH = 1e10


@dataclass(frozen=True)
class RenderPass:
    name: str          # the engine's key; Blender's pass name up to 4.5
    channels: int
    chan_id: str       # Blender's channel letters
    kind: str          # Blender's pass type: VALUE, VECTOR or COLOR
    view_layer: str    # the ViewLayer property that asks for it
    provided: bool     # the engine computes it today
    title: str = ""    # Blender 5.0's name for it (its multi-layer EXRs' layer name)
    option: str = ""   # the command line's name (`--passes`); a Cryptomatte's levels share one
    matte: str = ""    # a Cryptomatte level: its matte's layer name (CryptoObject, ...)

    def blender_name(self, version=(5, 0)) -> str:
        """The pass's name in this Blender version."""
        return self.title if tuple(version) >= (5, 0) else self.name

    @property
    def file_channels(self) -> str:
        """Channel letters in a multi-layer EXR: Cryptomatte's are lower case (the
        specification's, and Blender writes them so)."""
        return self.chan_id.lower() if self.matte else self.chan_id


# Cryptomatte: the specification's suggested and Blender's default depth, 6 ranks, two
# per RGBA layer. The engine always computes a matte's levels together.
MATTE_LEVELS = 3
MATTES = {"CryptoObject": ("use_pass_cryptomatte_object", "crypto_object"),
          "CryptoMaterial": ("use_pass_cryptomatte_material", "crypto_material"),
          "CryptoAsset": ("use_pass_cryptomatte_asset", "crypto_asset")}

PASSES = {p.name: p for p in (
    RenderPass("Depth", 1, "Z", "VALUE", "use_pass_z", True, "Depth", "depth"),
    RenderPass("Normal", 3, "XYZ", "VECTOR", "use_pass_normal", True, "Normal", "normal"),
    RenderPass("Emit", 3, "RGB", "COLOR", "use_pass_emit", True, "Emission", "emission"),
    RenderPass("IndexOB", 1, "X", "VALUE", "use_pass_object_index", True, "Object Index",
               "object_index"),
    RenderPass("IndexMA", 1, "X", "VALUE", "use_pass_material_index", True, "Material Index",
               "material_index"),
    # Lighting passes (engine/gpu/passes/ao.py and ambient.py say what each holds).
    RenderPass("AO", 3, "RGB", "COLOR", "use_pass_ambient_occlusion", True,
               "Ambient Occlusion", "ambient_occlusion"),
    RenderPass("Shadow", 3, "RGB", "COLOR", "use_pass_shadow", True, "Shadow", "shadow"),
    RenderPass("DiffDir", 3, "RGB", "COLOR", "use_pass_diffuse_direct", True,
               "Diffuse Direct", "diffuse_direct"),
    RenderPass("DiffInd", 3, "RGB", "COLOR", "use_pass_diffuse_indirect", True,
               "Diffuse Indirect", "diffuse_indirect"),
    RenderPass("GlossDir", 3, "RGB", "COLOR", "use_pass_glossy_direct", True,
               "Glossy Direct", "glossy_direct"),
    RenderPass("GlossInd", 3, "RGB", "COLOR", "use_pass_glossy_indirect", True,
               "Glossy Indirect", "glossy_indirect"),
    RenderPass("Env", 3, "RGB", "COLOR", "use_pass_environment", True, "Environment",
               "environment"),
    *(RenderPass(f"{matte}{level:02d}", 4, "RGBA", "COLOR", switch, True,
                 f"{matte}{level:02d}", option, matte)
      for matte, (switch, option) in MATTES.items() for level in range(MATTE_LEVELS)),
)}

COMBINED = "Combined"   # always rendered: RenderResult.rgba
COMBINED_TITLE = "Combined"

# Hydra's AOV names (a RenderVar's sourceName) for what Lantern makes. primId is the
# prim's Object Index here (Blender's nearest pass), not Hydra's internal id.
HYDRA = {"color": COMBINED, "depth": "Depth", "normal": "Normal", "primId": "IndexOB"}


def provided() -> list:
    """The passes the engine computes today, in table order."""
    return [p for p in PASSES.values() if p.provided]


def switches() -> list:
    """(view-layer property, label) of each provided pass's switch, once each, in
    table order (a Cryptomatte's levels share theirs)."""
    seen = {}
    for p in provided():
        seen.setdefault(p.view_layer, p.matte or p.title)
    return list(seen.items())


def options() -> dict:
    """{command-line name: (pass names, ...)} of the provided passes, in table order."""
    out = {}
    for p in provided():
        out.setdefault(p.option, []).append(p.name)
    return {k: tuple(v) for k, v in out.items()}


def asked_by(view_layer) -> list:
    """The provided passes a Blender view layer asks for (any object with its
    `use_pass_*` properties), in table order."""
    return [p.name for p in provided() if getattr(view_layer, p.view_layer, False)]


def resolve(name: str):
    """The pass names a name given anywhere means: a command-line name
    (`diffuse_direct`, `crypto_object`), a Hydra AOV name (`color`, `depth`, `normal`,
    `primId`), a Blender name of either era (`DiffDir`, `Diffuse Direct`) or a
    Cryptomatte layer (`CryptoObject`, `CryptoObject00`). () for Combined; None when
    Lantern makes no such pass."""
    if name in HYDRA:
        name = HYDRA[name]
    if name in (COMBINED, "combined", "rgba", "C.*"):
        return ()
    by_option = options()
    if name in by_option:
        return by_option[name]
    for p in provided():
        if name in (p.name, p.title):
            return by_option[p.option] if p.matte else (p.name,)
        if name == p.matte:
            return by_option[p.option]
    return None


def check(names) -> frozenset:
    """The requested pass names, checked: Combined is always there and is dropped
    here; an unknown or not-yet-provided name is a ValueError naming it. A
    Cryptomatte level brings its matte's other levels (computed together)."""
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
        if p.matte:
            out.update(q.name for q in PASSES.values() if q.matte == p.matte)
        else:
            out.add(name)
    return frozenset(out)


def wants_ids(names) -> bool:
    """Whether these passes need the G-buffer's object and material ids (Cryptomatte)."""
    return any(PASSES[n].matte for n in names if n in PASSES)
