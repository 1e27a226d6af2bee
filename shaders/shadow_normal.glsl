// The shadow maps' normal texels (shadow.frag writes, shadow_lookup.glsl reads): a
// surface's geometric normal, octahedral (lib.glsl), or SEE_THROUGH for a caster with
// holes (a cut-out, a blended surface), whose texels are samples, not planes.
const float SEE_THROUGH = -1.0;
