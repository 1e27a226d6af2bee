// The dome's light, as engine/gpu/environment.py binds it: irradiance from order-2
// harmonics (in the dome's frame), reflections from the prefiltered cube (a level per
// roughness, lod = L r (2 - r)), the background from the lat-long map itself. A
// uniform dome (no HAS_DOME_MAP) is exact: a constant radiance everywhere.
uniform vec3 dome_sh[9];         // irradiance, radiance scale included
uniform vec3 dome_radiance;      // colour x intensity (the map's multiplier)
uniform mat3 dome_to_local;      // world -> the dome's frame
#ifdef HAS_DOME_MAP
uniform sampler2D latlong;
uniform samplerCube env_specular;
uniform float env_lod_max;
#endif

vec3 dome_background(vec3 d) {
#ifdef HAS_DOME_MAP
    vec3 l = normalize(dome_to_local * d);
    vec2 uv = vec2((atan(l.z, l.x) + 0.5 * PI) / (2.0 * PI), acos(clamp(l.y, -1.0, 1.0)) / PI);
    return textureLod(latlong, uv, 0.0).rgb * dome_radiance;
#else
    return dome_radiance;
#endif
}

// Irradiance on a surface of normal n.
vec3 dome_irradiance(vec3 n) {
    return max(sh_irradiance(dome_sh, dome_to_local * n), vec3(0.0));
}

// Radiance prefiltered with the GGX lobe of perceptual roughness r about direction d.
vec3 dome_specular(vec3 d, float r) {
#ifdef HAS_DOME_MAP
    return textureLod(env_specular, dome_to_local * d, env_lod_max * r * (2.0 - r)).rgb * dome_radiance;
#else
    return dome_radiance;
#endif
}
