#version 330 core
#include "lib.glsl"
// One light, added into the HDR target (blend ONE, ONE). Variants: LIGHT_DISTANT
// (full-screen), LIGHT_SPHERE (point and spot, drawn as a light volume), LIGHT_AREA
// (rect and disk as a polygon, drawn as a light volume). See engine/usd/lights.py for
// the light forms; the light itself, and what it reflects, come from lights.glsl.
uniform sampler2D g_base;
uniform sampler2D g_normal;
uniform sampler2D g_mat;
uniform sampler2D g_depth;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;

#include "lights.glsl"
#ifdef LIGHTS_INSTANCED
flat in int v_light;        // many shadowless sphere lights in one draw (volume.vert)
#else
uniform int light_index;
#endif

// The HDR target is RGBA16F: one light never writes more than it holds.
const float HDR_MAX = 65000.0;

#ifdef HAS_SHADOW
#include "shadow_lookup.glsl"
#endif

out vec4 frag;

void main() {
#ifdef LIGHTS_INSTANCED
    load_light(v_light, cam_forward);
#else
    load_light(light_index, cam_forward);
#endif
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) discard;
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    vec3 p = position_from_depth(uv, depth, inv_view_proj);   // camera-relative
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    Surface s = make_surface(p, n, v, texelFetch(g_base, px, 0), texelFetch(g_mat, px, 0));
    vec3 radiance = vec3(0.0);
#ifdef LIGHT_DISTANT
    radiance = distant_radiance(s);
#endif
#ifdef LIGHT_SPHERE
    radiance = sphere_radiance(s);
#endif
#ifdef LIGHT_AREA
    radiance = area_radiance(s);
#endif
    if (max(radiance.r, max(radiance.g, radiance.b)) <= 0.0) discard;
#ifdef HAS_SHADOW
    radiance *= light_shadow(p, n, dot(p, cam_forward));
#endif
    frag = vec4(min(finite(radiance), vec3(HDR_MAX)), 0.0);
}
