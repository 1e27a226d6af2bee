#version 330 core
#ifdef CONTACT_RAYS
// The ray tracer's watertight test (precise, and doubles) and the table of what a
// contact ray sees through (shadow_lookup.glsl's contact rays): only in a frame that
// bounces light, which has GL 4.3 and so these.
#extension GL_ARB_shader_storage_buffer_object : require
#extension GL_ARB_gpu_shader5 : require
#extension GL_ARB_gpu_shader_fp64 : require
#endif
#include "lib.glsl"
// One light, added into the HDR target (blend ONE, ONE). Variants, one kind each
// (lights.glsl): LIGHT_DISTANT (full-screen), LIGHT_SPHERE and LIGHT_SPOT (point, spot:
// drawn as a light volume), LIGHT_AREA (rect and disk as a polygon, drawn as a light
// volume). See engine/usd/lights.py for the light forms; the light itself, and what it
// reflects, come from lights.glsl.
#include "gbuffer_surface.glsl"
#include "lights.glsl"
#ifdef LIGHTS_INSTANCED
flat in int v_light;        // many shadowless sphere lights in one draw (volume.vert)
#else
uniform int light_index;
#endif

#ifdef HAS_SHADOW
#include "shadow_lookup.glsl"
#endif

layout(location = 0) out vec4 frag;
#ifdef WRITE_AOVS
// Render passes (engine/gpu/passes/ambient.py LIGHTING_AOVS), added like the light.
layout(location = 1) out vec4 aov_diffuse;
layout(location = 2) out vec4 aov_glossy;
layout(location = 3) out vec4 aov_shadow;   // luminance with shadows, without
#endif

void main() {
#ifdef LIGHTS_INSTANCED
    load_light(v_light, cam_forward);
#else
    load_light(light_index, cam_forward);
#endif
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) discard;
    Surface s = gbuffer_surface(px, depth);
    vec3 p = s.p, n = s.n;
    vec3 diffuse, glossy;        // what the light reflects diffusely, and specularly
    light_reflected(s, diffuse, glossy);
    vec3 radiance = diffuse + glossy;
    if (max(radiance.r, max(radiance.g, radiance.b)) <= 0.0) discard;
    vec3 lit = vec3(1.0);        // the shadow, coloured by the glass it passes
#ifdef HAS_SHADOW
    lit = light_shadow(p, n, dot(p, cam_forward)) * light_shadow_colour(p, n, dot(p, cam_forward));
#endif
    frag = vec4(radiance * lit, 0.0);   // NaN or Inf goes through: the resolve pass counts it
#ifdef WRITE_AOVS
    aov_diffuse = vec4(diffuse * lit, 0.0);
    aov_glossy = vec4(glossy * lit, 0.0);
    float luminance = dot(radiance, vec3(0.2126, 0.7152, 0.0722));
    aov_shadow = vec4(dot(radiance * lit, vec3(0.2126, 0.7152, 0.0722)), luminance, 0.0, 0.0);
#endif
}
