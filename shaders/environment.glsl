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

// --- What the dome reflects off a surface: the ambient pass (opaque surfaces) and the
// transparency pass (blended ones) both call this, so both are lit alike.
uniform bool has_dome;

// Lagarde and de Rousiers 2014: the visible share of a specular lobe, from AO.
float specular_occlusion(float NoV, float ao, float roughness) {
    return clamp(pow(NoV + ao, exp2(-16.0 * roughness - 1.0)) - 1.0 + ao, 0.0, 1.0);
}

// The dome's light leaving surface s, diffuse and glossy (the base lobe and the coat),
// its ambient occlusion `ao` applied; 0 without a dome.
void dome_light(Surface s, float ao, out vec3 diffuse, out vec3 glossy) {
    diffuse = vec3(0.0);
    glossy = vec3(0.0);
    if (!has_dome) return;
    vec3 E = dome_irradiance(s.n);
    diffuse = brdf_diffuse(s) * E * ao * bump_dome(s);
#ifdef SHEEN
    diffuse += sheen_ambient(s, E) * ao;
#endif
    vec3 r = reflect(-s.v, s.n);
    glossy = s.under_coat * s.spec_albedo * dome_specular(r, s.roughness)
           * specular_occlusion(s.NoV, ao, s.roughness);
    if (s.coat > 0.0)
        glossy += s.coat_albedo * dome_specular(r, s.coat_roughness)
                * specular_occlusion(s.NoV, ao, s.coat_roughness);
}
