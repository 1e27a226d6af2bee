"""Sheen lobes: the one table. The exporter writes a material's sheen as one of these
modes (`lantern:sheenMode`, docs/stage_contract.md "Sheen"), the engine draws it; a
mode's position is its number in the G-buffer (shaders/lib.glsl apply_sheen).

  principled  the Principled BSDF's Sheen: Cycles' microfiber sheen (Zeltner et al.
              2022) layered on top, so the layers below receive 1 - its albedo
  microfiber  a Sheen BSDF (Microfiber) added to the surface (Add Shader): no layering
  ashikhmin   a Sheen BSDF (Ashikhmin: Cycles' velvet) added to the surface"""
MODES = ("principled", "microfiber", "ashikhmin")

# Blender's Sheen BSDF distribution -> mode.
DISTRIBUTIONS = {"MICROFIBER": "microfiber", "ASHIKHMIN": "ashikhmin"}
