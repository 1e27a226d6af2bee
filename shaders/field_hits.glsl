// A traced ray's hit shaded as the irradiance field's probes shade theirs (engine/gpu/
// passes/irradiance.py): its emission, plus its albedo / pi times the light arriving
// there (every light of the light table, seen by a shadow ray, and the field's
// irradiance: the bounces so far). Glass (a material that transmits) passes shadow rays
// straight on, weighted by its transmittance. Shared by the probes' rays
// (irradiance_trace.comp) and the final gather's (gather_trace.comp). Include
// after lib.glsl, lights.glsl, environment.glsl, raytrace.glsl and irradiance_field.glsl.
uniform sampler2D field_materials;   // FIELD_MATERIAL texels a material: albedo,
                                     // (emission, sides), (transmittance colour, ior)
#define FIELD_MATERIAL 3
#define FIELD_GLASS_HITS 8           // glass surfaces a ray passes, at most
// Per traced instance (field_tables.py instance_sides): 4 its faces are made lights where
// they emit, 8 its mesh is closed. A material's sides (1 front, 2 back: its emission
// sampling) of such faces are lights of the light table, which bring their light per
// pixel: a ray that meets them takes no emission there (engine/emitters.py closed_sides).
layout(std430, binding = 15) readonly buffer FieldSides { int field_sides[]; };
uniform int n_lights;
uniform vec3 field_eye;             // the camera's world position
uniform bool u_bounce;               // the field read holds a bounce already
uniform float u_epsilon;
uniform vec3 u_view_forward;         // where a headlight shines
uniform bool u_glass;                // some traced material transmits

// What a hit's material lets through along dir (0 for an opaque one): its transmittance
// colour, less the dielectric Fresnel reflection at the hit's angle.
vec3 glass_through(RtHit hit, vec3 dir) {
    vec4 glass = texelFetch(field_materials, ivec2(FIELD_MATERIAL * rt_hit_material(hit) + 2, 0), 0);
    if (max(glass.r, max(glass.g, glass.b)) <= 0.0) return vec3(0.0);
    float c = abs(dot(rt_hit_normal(hit), normalize(dir)));
    return glass.rgb * (1.0 - fresnel_dielectric(c, glass.a));
}

// What reaches x of the loaded light: 1, 0 behind an opaque surface, glass's
// transmittance through glass.
vec3 light_through(vec3 x, vec3 n) {
    vec3 o = x + n * u_epsilon;
    vec3 to_light = is_distant ? -light_axis : light_pos - o;
    float far = is_distant ? RT_FAR : 1.0 - 1e-4;
    if (!u_glass) return rt_any_hit(o, to_light, 0.0, far) ? vec3(0.0) : vec3(1.0);
    vec3 weight = vec3(1.0);
    float tmin = 0.0;
    for (int k = 0; k < FIELD_GLASS_HITS; ++k) {
        RtHit hit;
        if (!rt_closest_hit(o, to_light, tmin, far, hit)) return weight;
        weight *= glass_through(hit, to_light);
        if (max(weight.r, max(weight.g, weight.b)) <= 0.0) break;
        tmin = hit.t + u_epsilon / length(to_light);
    }
    return vec3(0.0);
}

// The light a ray's hit sends back along -dir: its emission (but where it is a light of
// the light table) and the lights seen from it; `bounced`: the field's bounce so far,
// read as seen from the ray's start (a probe's: the read's self-shadowing bias towards
// the probe), or (`from_surface`: a ray from a surface, a final gather's) as below.
vec3 hit_radiance(RtHit hit, vec3 x, vec3 dir, bool from_surface, out vec3 bounced) {
    bounced = vec3(0.0);
    vec3 n = rt_hit_normal(hit);
    bool back = dot(n, dir) > 0.0;
    if (back) n = -n;                    // lit on either side, as Cycles' surfaces
    int m = rt_hit_material(hit);
    vec3 albedo = texelFetch(field_materials, ivec2(FIELD_MATERIAL * m, 0), 0).rgb;
    vec4 emission = texelFetch(field_materials, ivec2(FIELD_MATERIAL * m + 1, 0), 0);
    int sampled = int(emission.a), mesh = field_sides[hit.instance];
    bool lit_front = (mesh & 4) != 0 && (sampled & 1) != 0;
    bool lit_back = (mesh & 4) != 0 && (sampled & 2) != 0 && !((mesh & 8) != 0 && lit_front);
    vec3 radiance = (back ? lit_back : lit_front) ? vec3(0.0) : emission.rgb;
    if (max(albedo.r, max(albedo.g, albedo.b)) <= 0.0) return radiance;
    Surface s = make_surface(x, n, n, vec4(albedo, 1.0), vec4(0.0, 1.0, 0.0, 0.0));
    for (int i = 0; i < n_lights; ++i) {
        load_light(i, u_view_forward);
        // The shadow ray first: a light it finds hidden costs no integral.
        vec3 through = light_through(x, n);
        if (max(through.r, max(through.g, through.b)) <= 0.0) continue;
        vec3 diffuse, glossy;
        light_reflected(s, diffuse, glossy);
        radiance += diffuse * through;
    }
    if (!u_bounce) return radiance;
    if (!from_surface) {
        bounced = albedo / FIELD_PI * field_irradiance_at(x, n, -dir);
        return radiance;
    }
    // Back along a ray that started on a surface, the read's bias can reach past that
    // surface (reading probes beyond it); along the hit's normal it cannot, but a wall's
    // probes read less well there; a hit a few centimetres from the ray's start, in a
    // room's corner, reads by both the probes outside beyond the next wall, and towards
    // the camera (which sees the ray's start; only where the hit faces it) it does not.
    // The least of the three, the back one at most half way to the ray's start (a
    // sealed room's walls took none's leak: tests/test_irradiance_field.py).
    vec3 step = field_step[0];
    float reach = FIELD_BIAS_ALONG_V * field_bias * min(step.x, min(step.y, step.z));
    vec3 behind = -dir * min(1.0, 0.5 * hit.t / max(reach, 1e-6));
    vec3 E = min(field_irradiance_at(x, n, behind), field_irradiance_at(x, n, n));
    vec3 to_eye = field_eye - x;
    if (dot(to_eye, n) > 0.0) E = min(E, field_irradiance_at(x, n, normalize(to_eye)));
    bounced = albedo / FIELD_PI * E;
    return radiance;
}

// The light a ray from `origin` along unit `dir` brings (`from_surface`: hit_radiance's):
// each surface it meets shaded by hit_radiance, through glass (weighted by its
// transmittance) to the first surface that is not glass; the dome where it escapes
// (has_dome: environment.glsl). `bounced`: the
// share the field brought; `distance`: to that first opaque surface (1e27 where the ray
// escaped), negative where it met the surface's back (its winding); `facing`: that
// surface's normal towards the origin (0 where none).
vec3 traced_radiance(vec3 origin, vec3 dir, bool from_surface, out vec3 bounced,
                     out float distance, out vec3 facing) {
    vec3 radiance = vec3(0.0), weight = vec3(1.0);
    bounced = facing = vec3(0.0);
    distance = 1.0e27;
    float tmin = 0.0;
    for (int k = 0; k < FIELD_GLASS_HITS; ++k) {
        RtHit hit;
        if (!rt_closest_hit(origin, dir, tmin, RT_FAR, hit)) {
            if (has_dome) radiance += weight * dome_background(dir);
            break;
        }
        vec3 hit_bounced;
        radiance += weight * hit_radiance(hit, origin + hit.t * dir, dir, from_surface, hit_bounced);
        bounced += weight * hit_bounced;
        vec3 through = glass_through(hit, dir);
        vec3 n = rt_hit_normal(hit);
        bool back = dot(n, dir) > 0.0;
        distance = back ? -hit.t : hit.t;
        facing = back ? -n : n;
        weight *= through;
        if (max(weight.r, max(weight.g, weight.b)) <= 0.0) break;
        tmin = hit.t + u_epsilon;
        distance = 1.0e27;                   // through glass: what lies beyond it
        facing = vec3(0.0);
    }
    return radiance;
}
