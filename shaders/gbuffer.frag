#version 330 core
#include "lib.glsl"
// G-buffer: RT0 base colour + alpha, RT1 world normal + clearcoat roughness, RT2
// metallic / roughness / dielectric F0 / clearcoat, RT3 emission + the base-occlusion mark
// (alpha: BASE_OCCLUSION in the lighting passes); then, in the frames that need them,
// the smooth normal and the sheen (lib.glsl apply_sheen). The material itself is
// material.glsl's. DEPTH_ONLY: the edge samples' drawing (engine/gpu/passes/gbuffer.py),
// into a depth target alone: the alpha test, and no material.
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
layout(location = 0) out vec4 rt_base;
layout(location = 1) out vec4 rt_normal;
layout(location = 2) out vec4 rt_mat;
layout(location = 3) out vec4 rt_emit;
#ifdef WRITE_SMOOTH_NORMAL
// The normal before the normal map, in frames with a normal-mapped material (the bump
// map correction, lib.glsl bump_shadowing).
layout(location = 4) out vec4 rt_smooth;
#define SHEEN_LOCATION 5
#else
#define SHEEN_LOCATION 4
#endif
#ifdef WRITE_SHEEN
layout(location = SHEEN_LOCATION) out vec4 rt_sheen;   // u_sheen (material.glsl)
#if SHEEN_LOCATION == 5
#define INDEX_LOCATION 6
#else
#define INDEX_LOCATION 5
#endif
#else
#define INDEX_LOCATION SHEEN_LOCATION
#endif
#ifdef WRITE_INDEX
// Render passes IndexOB and IndexMA, and the ids Cryptomatte ranks (asked for only):
// the object's pass index, the material's, 1 + the object's id, the material's
// Cryptomatte id (engine/gpu/passes/cryptomatte.py).
layout(location = INDEX_LOCATION) out vec4 rt_index;
flat in float v_object_index;
flat in float v_object_id;
uniform float u_material_index;
uniform float u_material_id;
#endif

#include "material.glsl"

void main() {
    float alpha = material_alpha(v_uv);
    // A cut-out's threshold, or a blended material's opaque texels (Material.alpha).
    if (u_opacity_threshold > 0.0 && alpha < u_opacity_threshold) discard;
#ifndef DEPTH_ONLY
    MaterialSample m = material_sample(v_uv, v_normal, v_tangent, gl_FrontFacing);
    rt_base = vec4(m.base * (1.0 - u_transmission), alpha);   // glass: its diffuse share
    rt_normal = vec4(m.n, m.coat_roughness);
    rt_mat = m.mat;
    rt_emit = vec4(m.emissive, u_base_occlusion);   // .a: BASE_OCCLUSION (light.frag)
#ifdef WRITE_SMOOTH_NORMAL
    rt_smooth = vec4(m.smooth_n, 0.0);
#endif
#ifdef WRITE_SHEEN
    rt_sheen = m.sheen;
#endif
#ifdef WRITE_INDEX
    rt_index = vec4(v_object_index, u_material_index, v_object_id, u_material_id);
#endif
#endif
}
