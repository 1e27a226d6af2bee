#version 330 core
#include "lib.glsl"
// One face of one level of an environment cube map (engine/gpu/environment.py), in
// the dome's own frame. Variants:
// ENV_FROM_LATLONG  the radiance cube's level 0, resampled from the lat-long map
//                   (UsdLux's convention: +Y up, u = (atan2(z, x) + pi/2) / 2pi),
//                   less the radiance its order-2 harmonics hold: the shaders average
//                   those over a lobe exactly (environment.glsl dome_specular), and
//                   the cubes keep the rest.
// (none)            a prefiltered level: the radiance cube convolved with the GGX
//                   lobe of `roughness` for n = v = r (Karis' split sum), by
//                   importance sampling with filtered lookups (Krivanek and Colbert
//                   2008: each sample reads the mip whose texel matches its solid
//                   angle), so few samples give no fireflies.
uniform int face;          // GL's order: +X, -X, +Y, -Y, +Z, -Z
uniform int face_size;     // this level's texels per side
#ifdef ENV_FROM_LATLONG
uniform sampler2D latlong;
uniform float latlong_lod; // the map's mip whose texels match this face's
uniform vec3 map_sh[9];    // the map's irradiance harmonics (engine/lighting.py latlong_sh)
#else
uniform samplerCube radiance;
uniform float radiance_size;   // level 0 texels per side
uniform float roughness;
uniform int samples;
#endif
out vec4 frag;

// The direction of a face texel, as GL's cube-map lookup selects it.
vec3 face_direction(vec2 uv) {
    vec2 c = uv * 2.0 - 1.0;
    if (face == 0) return vec3(1.0, -c.y, -c.x);
    if (face == 1) return vec3(-1.0, -c.y, c.x);
    if (face == 2) return vec3(c.x, 1.0, c.y);
    if (face == 3) return vec3(c.x, -1.0, -c.y);
    if (face == 4) return vec3(c.x, -c.y, 1.0);
    return vec3(-c.x, -c.y, -1.0);
}

#ifndef ENV_FROM_LATLONG
vec2 hammersley(int i, int n) {
    uint b = uint(i);
    b = (b << 16u) | (b >> 16u);
    b = ((b & 0x55555555u) << 1u) | ((b & 0xAAAAAAAAu) >> 1u);
    b = ((b & 0x33333333u) << 2u) | ((b & 0xCCCCCCCCu) >> 2u);
    b = ((b & 0x0F0F0F0Fu) << 4u) | ((b & 0xF0F0F0F0u) >> 4u);
    b = ((b & 0x00FF00FFu) << 8u) | ((b & 0xFF00FF00u) >> 8u);
    return vec2((float(i) + 0.5) / float(n), float(b) * 2.3283064365386963e-10);
}
#endif

void main() {
    vec3 d = normalize(face_direction(gl_FragCoord.xy / float(face_size)));
#ifdef ENV_FROM_LATLONG
    vec2 uv = vec2((atan(d.z, d.x) + 0.5 * PI) / (2.0 * PI), acos(clamp(d.y, -1.0, 1.0)) / PI);
    vec3 smooth_part = sh_radiance_mean(map_sh, d, outerProduct(d, d));
    frag = vec4(textureLod(latlong, uv, latlong_lod).rgb - smooth_part, 1.0);
#else
    float a = ggx_alpha(roughness);
    vec3 up = abs(d.z) < 0.999 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
    vec3 tx = normalize(cross(up, d));
    vec3 ty = cross(d, tx);
    float texel_solid_angle = 4.0 * PI / (6.0 * radiance_size * radiance_size);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (int i = 0; i < samples; ++i) {
        vec2 u = hammersley(i, samples);
        float phi = 2.0 * PI * u.x;
        float cos_h = sqrt((1.0 - u.y) / (1.0 + (a * a - 1.0) * u.y));
        float sin_h = sqrt(1.0 - cos_h * cos_h);
        vec3 h = tx * (sin_h * cos(phi)) + ty * (sin_h * sin(phi)) + d * cos_h;
        vec3 l = 2.0 * dot(d, h) * h - d;
        float NoL = dot(d, l);
        if (NoL <= 0.0) continue;
        // pdf of l for n = v: D(h) / 4.
        float pdf = d_ggx(cos_h, a) * 0.25;
        float sample_solid_angle = 1.0 / (float(samples) * pdf + 1e-6);
        float lod = max(0.5 * log2(sample_solid_angle / texel_solid_angle) + 1.0, 0.0);
        sum += textureLod(radiance, l, lod).rgb * NoL;
        weight += NoL;
    }
    frag = vec4(sum / max(weight, 1e-6), 1.0);
#endif
}
