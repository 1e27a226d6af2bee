"""Emission sampling: the one table. Blender's Material > Settings > Emission Sampling
(`material.cycles.emission_sampling`) says which faces of a mesh with that material
light other surfaces; the exporter writes it as `lantern:emissionSampling` (a token,
docs/stage_contract.md "Emission"), only where it is not Cycles' default, and the
engine makes the emitting faces lights (engine/emitters.py). Every face still shows
its own emission, whatever the setting.

  none   lights nothing (Cycles still finds it by BSDF sampling: noisier, not nothing)
  auto   Cycles' default: an emission closure emits from both faces, so both light
  front  the face the polygon's normal points from
  back   the other face
  both   both faces"""
# token -> (front face lights, back face lights)
SAMPLING = {"none": (False, False), "auto": (True, True), "front": (True, False),
            "back": (False, True), "both": (True, True)}
DEFAULT = "auto"

# Blender's enum (bpy 5.0 CyclesMaterialSettings.emission_sampling) -> token.
BLENDER = {"NONE": "none", "AUTO": "auto", "FRONT": "front", "BACK": "back",
           "FRONT_BACK": "both"}
