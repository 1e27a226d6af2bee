#version 330 core
#include "lib.glsl"
// Full screen, once: dome lighting (SH irradiance for diffuse, an analytic env-BRDF
// for specular), emission, and the dome as the background where nothing was drawn.
// Positions are camera-relative (lib.glsl): the viewer is at the origin.
uniform sampler2D g_base;
uniform sampler2D g_normal;
uniform sampler2D g_mat;
uniform sampler2D g_emit;
uniform sampler2D g_depth;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;

uniform bool has_dome;
uniform vec3 dome_sh[9];
uniform vec3 dome_radiance;
uniform bool transparent;
#ifdef HAS_DOME_MAP
uniform sampler2D dome_map;
uniform mat3 dome_to_local;    // world -> dome frame
#endif

out vec4 frag;

// Karis' mobile env-BRDF fit, with F90 (not 1) on the second term so f0 = 0 gives 0.
vec3 env_brdf(vec3 f0, vec3 f90, float roughness, float NoV) {
    const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
    const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
    vec4 r = roughness * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * NoV)) * r.x + r.y;
    vec2 ab = vec2(-1.04, 1.04) * a004 + r.zw;
    return f0 * ab.x + f90 * ab.y;
}

vec3 dome(vec3 d) {
#ifdef HAS_DOME_MAP
    vec3 l = normalize(dome_to_local * d);
    vec2 uv = vec2((atan(l.z, l.x) + 0.5 * PI) / (2.0 * PI), acos(clamp(l.y, -1.0, 1.0)) / PI);
    return textureLod(dome_map, uv, 0.0).rgb * dome_radiance;
#else
    return dome_radiance;
#endif
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(g_depth, px, 0).r;
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    if (is_background(depth)) {
        vec3 bg = vec3(0.0);
        if (has_dome && !transparent)
            bg = dome(pixel_ray(uv, inv_view_proj, cam_ortho, cam_forward));
        frag = vec4(bg, 0.0);
        return;
    }
    vec3 p = position_from_depth(uv, depth, inv_view_proj);
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    Surface s = make_surface(p, n, v, texelFetch(g_base, px, 0), texelFetch(g_mat, px, 0));
    vec3 c = texelFetch(g_emit, px, 0).rgb;
    if (has_dome) {
        vec3 irradiance = max(sh_irradiance(dome_sh, n), vec3(0.0));
        c += brdf_diffuse(s) * irradiance;
        // Specular radiance: the irradiance-weighted average around the reflection
        // direction, E(r)/pi (exact for a uniform dome).
        vec3 r = reflect(-v, n);
        vec3 spec_l = max(sh_irradiance(dome_sh, r), vec3(0.0)) / PI;
        c += env_brdf(s.f0, s.f90, s.roughness, max(dot(n, v), 1e-4)) * spec_l;
    }
    frag = vec4(c, 0.0);
}
