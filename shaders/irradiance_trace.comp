#version 430 core
// The irradiance field's rays (engine/gpu/passes/irradiance.py): a work group of 64
// invocations a block of one probe's rays, one ray an invocation, each traced to its
// closest hit (raytrace.glsl) and shaded there with one more bounce than the field it
// reads: the hit's emission, plus its albedo / pi times the light arriving there (every
// light of the light table, seen by a shadow ray, and the field's irradiance: the
// bounces so far); a ray that escapes sees the dome. Glass (a material that transmits)
// passes light straight on, rays and shadow rays alike: a ray that meets it adds what its
// diffuse share shades and goes on weighted by its transmittance (the tint, and 1 - the
// dielectric Fresnel at that angle: a flat pane's two faces exactly; a curved object's
// refraction is not followed), so sky and sun reach what lies under it. Writes per ray
// its radiance, split in what the field does not bring (emission, the lights, the dome:
// the same from one update to the next) and the field's bounces, the distance to the first
// surface that is not glass (probes see through glass), negative where the ray met a
// triangle's back (its winding), and that surface's normal, towards the probe.
#include "lib.glsl"
#include "lights.glsl"
#include "environment.glsl"
#include "raytrace.glsl"
#include "irradiance_field.glsl"
layout(local_size_x = 64) in;
// x ray, y probe: (the radiance the field does not bring, signed distance); x u_rays +
// ray: the hit's normal, towards the probe (0 where the ray escaped); x 2 u_rays + ray:
// the radiance the field brings (its bounces so far)
layout(rgba32f, binding = 0) writeonly uniform image2D ray_image;
uniform sampler2D field_materials;   // FIELD_MATERIAL texels a material: albedo,
                                     // (emission, sides), (transmittance colour, ior)
#define FIELD_MATERIAL 3
#define FIELD_GLASS_HITS 8           // glass surfaces a ray passes, at most
// Per traced instance (field_tables.py instance_sides): 4 its faces are made lights where
// they emit, 8 its mesh is closed. A material's sides (1 front, 2 back: its emission
// sampling) of such faces are lights of the light table, which bring their light per
// pixel: a ray that meets them takes no emission there (engine/emitters.py closed_sides).
layout(std430, binding = 15) readonly buffer FieldSides { int field_sides[]; };
uniform mat3 u_rotation;
uniform int u_rays;                  // a probe's
uniform int n_lights;
uniform bool u_bounce;               // the field read holds a bounce already
uniform int u_first_probe;           // the first probe of those this dispatch updates
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
// the light table) and the lights seen from it; `bounced`: the field's bounce so far.
vec3 hit_radiance(RtHit hit, vec3 x, vec3 dir, out vec3 bounced) {
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
        vec3 diffuse, glossy;
        light_reflected(s, diffuse, glossy);
        if (max(diffuse.r, max(diffuse.g, diffuse.b)) > 0.0)
            radiance += diffuse * light_through(x, n);
    }
    if (u_bounce)
        bounced = albedo / FIELD_PI * field_irradiance_at(x, n, -dir);
    return radiance;
}

void main() {
    int probe = u_first_probe + int(gl_WorkGroupID.y);
    int ray = int(gl_WorkGroupID.x) * 64 + int(gl_LocalInvocationID.x);
    if (ray >= u_rays) return;
    // The first update starts from probes at their grid places, on.
    vec4 state = u_bounce ? probe_state(probe) : vec4(0.0, 0.0, 0.0, 1.0);
    int g = probe_grid(probe);
    vec3 origin = probe_position(g, probe_cell(g, probe), state);
    vec3 dir = fibonacci_ray(ray, u_rays, u_rotation);
    vec3 radiance = vec3(0.0), bounced = vec3(0.0), weight = vec3(1.0), facing = vec3(0.0);
    float distance = 1.0e27, tmin = 0.0;
    for (int k = 0; k < FIELD_GLASS_HITS; ++k) {
        RtHit hit;
        if (!rt_closest_hit(origin, dir, tmin, RT_FAR, hit)) {
            if (has_dome) radiance += weight * dome_background(dir);
            break;
        }
        vec3 hit_bounced;
        radiance += weight * hit_radiance(hit, origin + hit.t * dir, dir, hit_bounced);
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
    imageStore(ray_image, ivec2(ray, probe), vec4(radiance, distance));
    imageStore(ray_image, ivec2(u_rays + ray, probe), vec4(facing, 0.0));
    imageStore(ray_image, ivec2(2 * u_rays + ray, probe), vec4(bounced, 0.0));
}
