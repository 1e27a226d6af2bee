// The dome (the world light): what it reflects off a surface and what a ray sees.
// Shared by the ambient pass (opaque surfaces, the background) and the transparency
// pass, so both are lit by the same environment term. Include after lib.glsl.
// Uniforms: engine/gpu/passes/ambient.py set_environment.
uniform bool has_dome;
uniform vec3 dome_sh[9];
uniform vec3 dome_radiance;
#ifdef HAS_DOME_MAP
uniform sampler2D dome_map;
uniform mat3 dome_to_local;    // world -> dome frame
#endif

// Karis' mobile env-BRDF fit, with F90 (not 1) on the second term so f0 = 0 gives 0.
vec3 env_brdf(vec3 f0, vec3 f90, float roughness, float NoV) {
    const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
    const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
    vec4 r = roughness * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * NoV)) * r.x + r.y;
    vec2 ab = vec2(-1.04, 1.04) * a004 + r.zw;
    return f0 * ab.x + f90 * ab.y;
}

// The dome's radiance along world direction d.
vec3 dome(vec3 d) {
#ifdef HAS_DOME_MAP
    vec3 l = normalize(dome_to_local * d);
    vec2 uv = vec2((atan(l.z, l.x) + 0.5 * PI) / (2.0 * PI), acos(clamp(l.y, -1.0, 1.0)) / PI);
    return textureLod(dome_map, uv, 0.0).rgb * dome_radiance;
#else
    return dome_radiance;
#endif
}

// What the dome reflects off surface s (0 without a dome).
vec3 environment_radiance(Surface s) {
    if (!has_dome) return vec3(0.0);
    vec3 irradiance = max(sh_irradiance(dome_sh, s.n), vec3(0.0));
    vec3 c = brdf_diffuse(s) * irradiance;
    // Specular radiance: the irradiance-weighted average around the reflection
    // direction, E(r)/pi (exact for a uniform dome).
    vec3 r = reflect(-s.v, s.n);
    vec3 spec_l = max(sh_irradiance(dome_sh, r), vec3(0.0)) / PI;
    return c + env_brdf(s.f0, s.f90, s.roughness, max(dot(s.n, s.v), 1e-4)) * spec_l;
}
