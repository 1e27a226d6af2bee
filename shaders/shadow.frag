#version 330 core
// Depth only. Radial maps (spot, cube) store distance / far, the same quantity on
// every cube face, so the lookup compares radial distances and PCSS reads blocker
// distances without un-projecting. Ortho (sun) depth is linear already.
//
// ALPHA_TEST (see-through materials, engine/gpu/passes/shadows.py): a cut-out casts
// only where its alpha reaches its threshold, as the G-buffer draws it. A blended
// surface casts where its alpha exceeds a per-texel threshold spread evenly over
// (0, 1): stochastic transparency (Enderton et al. 2010). Shadow filtering averages
// those texels, so a layer of alpha a lets 1 - a of the light through, and layers
// multiply, as Cycles' transparent shadows do.
//
// EXIT (an area light's second layer, passes/shadow_exits.py): the nearest surface
// beyond the map's own, where the first caster along the texel's ray ends.
//
// TINT (glass casters, passes/shadows.py): no depth; the colour target takes the
// caster's tint, multiplied over every face of glass along the texel's ray (its
// Fresnel and transmission are the stochastic depth's), and the nearest glass's depth
// (blended by MIN): the lookup tints receivers behind it.
in vec3 v_world;
uniform bool radial;
uniform vec3 light_pos;        // anchor-relative (0 for radial maps)
uniform float far;
#ifdef ALPHA_TEST
in vec2 v_uv;
uniform int u_object;          // the caster (objects.glsl): its own thresholds
#include "lib.glsl"
#include "material.glsl"

// The thresholds of a blended caster: in every 4 x 4 block of map texels, the 16
// levels (k + 0.5) / 16 once each (a Bayer matrix, lib.glsl, so a block passes exactly
// round(16 a) texels, spread out), permuted per block and per caster by XOR with a
// hashed key, so the layers of different casters are independent.
uint hash3(uvec3 v) {
    uint h = v.x * 0x8da6b343u ^ v.y * 0xd8163841u ^ v.z * 0xcb1ab31fu;
    h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15; h *= 0x846ca68bu; h ^= h >> 16;
    return h;
}

float caster_threshold() {
    uvec2 p = uvec2(gl_FragCoord.xy);
    uint key = hash3(uvec3(p >> 2u, uint(u_object))) & 15u;
    uint b = bayer4(p);
    uint r = uint(u_object) & 3u;
    b = ((b << r) | (b >> (4u - r))) & 15u;
    return (float(b ^ key) + 0.5) / 16.0;
}
#endif

#ifdef EXIT
uniform sampler2D shadow_raw;  // the map's own depth
#endif

#ifdef TINT
uniform vec3 u_tint;
out vec4 tint;
#endif

void main() {
#ifdef TINT
    tint = vec4(u_tint, radial ? clamp(length(v_world - light_pos) / far, 0.0, 1.0) : gl_FragCoord.z);
    return;
#endif
#ifdef ALPHA_TEST
    float alpha = material_alpha(v_uv);
    float cut = u_opacity_threshold > 0.0 ? u_opacity_threshold : caster_threshold();
    if (alpha < cut) discard;
#endif
    float depth = radial ? clamp(length(v_world - light_pos) / far, 0.0, 1.0) : gl_FragCoord.z;
#ifdef EXIT
    // The map's own surface again (a program of its own may round it a little apart).
    if (depth <= texelFetch(shadow_raw, ivec2(gl_FragCoord.xy), 0).r * (1.0 + 1e-5) + 1e-7)
        discard;
#endif
    gl_FragDepth = depth;
}
