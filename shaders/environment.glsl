// The dome's light, as engine/gpu/environment.py binds it: irradiance from order-2
// harmonics (in the dome's frame); reflections from the same harmonics, averaged over
// the lobe exactly, plus what they miss, prefiltered in a cube (a level per roughness,
// lod = L r (2 - r)); the background from the lat-long map itself. A uniform dome (no
// HAS_DOME_MAP) is exact: a constant radiance everywhere.
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

// The dome's radiance averaged over the lobe: a lobe's albedo times this is its
// light. The split sum's one lookup along the mirror direction, of a map prefiltered
// for n = v = r, put a white metal of roughness 1 under a sky 17% too red above and
// 20% short of blue below: a rough lobe leans from the mirror direction towards n,
// and a grazing one is narrower across the plane of n and v than along it, and
// clipped by the horizon. So in two parts. The harmonics' share is exact whatever the
// lobe's shape: a quadratic function of direction, averaged from the lobe's first and
// second moments. The rest, the map less its harmonics (small, and sharp: a sun, a
// horizon), is prefiltered as Karis does and read along the lobe's dominant direction
// (Lagarde and de Rousiers 2014, getSpecularDominantDir).
vec3 dome_specular(Lobe lobe) {
#ifdef HAS_DOME_MAP
    vec3 tl = dome_to_local * lobe.t, nl = dome_to_local * lobe.n, bl = cross(nl, tl);
    mat3 S = lobe.second.x * outerProduct(tl, tl) + lobe.second.y * outerProduct(bl, bl)
           + lobe.second.z * outerProduct(nl, nl)
           + lobe.first.w * (outerProduct(tl, nl) + outerProduct(nl, tl));
    vec3 smooth_part = sh_radiance_mean(dome_sh, lobe.first.x * tl + lobe.first.z * nl, S);
    float r = lobe.roughness;
    vec3 dominant = specular_dominant(lobe.n, lobe.v, r);
    vec3 rest = textureLod(env_specular, dome_to_local * dominant, env_lod_max * r * (2.0 - r)).rgb;
    return max(smooth_part + rest * dome_radiance, vec3(0.0));
#else
    return dome_radiance;
#endif
}

// --- What the dome reflects off a surface: the ambient pass (opaque surfaces) and the
// transparency pass (blended ones) both call this, so both are lit alike.
uniform bool has_dome;

// The dome's light leaving surface s, diffuse and glossy (the base lobe and the coat),
// its occlusion applied: (ambient occlusion, the reflections' share the scene leaves)
// from the AO pass (ao.glsl), (1, 1) where there is none; 0 without a dome. The coat
// takes the base lobe's share.
void dome_light(Surface s, vec2 occlusion, out vec3 diffuse, out vec3 glossy) {
    diffuse = vec3(0.0);
    glossy = vec3(0.0);
    if (!has_dome) return;
    float ao = occlusion.x;
    vec3 E = dome_irradiance(s.n);
    diffuse = brdf_diffuse(s) * E * ao * bump_dome(s);
#ifdef SHEEN
    diffuse += sheen_ambient(s, E) * ao;
#endif
#ifndef GLOSSY_BOUNCE   // else the reflection pass adds the base lobe's (reflections.glsl)
    glossy = s.under_coat * s.spec_albedo
           * dome_specular(make_lobe(s.n, s.v, s.roughness, s.spec_dielectric));
#endif
    if (s.coat > 0.0)
        glossy += s.coat_albedo * dome_specular(make_lobe(s.n, s.v, s.coat_roughness, 1.0));
    glossy *= occlusion.y;
}
