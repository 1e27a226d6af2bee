#version 430 core
// The irradiance field's rays (engine/gpu/passes/irradiance.py): a work group of 64
// invocations a block of one probe's rays, one ray an invocation, each traced to its
// closest hit (raytrace.glsl) and shaded there with one more bounce than the field it
// reads: the hit's emission, plus its albedo / pi times the light arriving there (every
// light of the light table, seen by a shadow ray, and the field's irradiance: the
// bounces so far); a ray that escapes sees the dome. Writes (radiance, distance) per
// ray, distance negative where the ray met a triangle's back (its winding).
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
uniform sampler2D field_materials;   // two texels a material: albedo, (emission, sides)
// Per traced instance (irradiance.py _instance_sides): 4 its faces are made lights where
// they emit, 8 its mesh is closed. A material's sides (1 front, 2 back: its emission
// sampling) of such faces are lights of the light table, which bring their light per
// pixel: a ray that meets them takes no emission there (engine/emitters.py closed_sides).
layout(std430, binding = 15) readonly buffer FieldSides { int field_sides[]; };
uniform mat3 u_rotation;
uniform int u_rays;                  // a probe's
uniform int n_lights;
uniform bool u_bounce;               // the field read holds a bounce already
uniform float u_epsilon;
uniform vec3 u_view_forward;         // where a headlight shines             // a shadow ray's offset off its surface

// Whether nothing lies between x and the loaded light.
bool light_visible(vec3 x, vec3 n) {
    vec3 o = x + n * u_epsilon;
    if (is_distant) return !rt_any_hit(o, -light_axis, 0.0, RT_FAR);
    vec3 to_light = light_pos - o;
    return !rt_any_hit(o, to_light, 0.0, 1.0 - 1e-4);
}

void main() {
    int probe = int(gl_WorkGroupID.y);
    int ray = int(gl_WorkGroupID.x) * 64 + int(gl_LocalInvocationID.x);
    if (ray >= u_rays) return;
    vec3 origin = probe_position(probe_cell(probe), probe_state(probe));
    vec3 dir = fibonacci_ray(ray, u_rays, u_rotation);
    RtHit hit;
    vec3 radiance = vec3(0.0);
    float distance = 1.0e27;
    vec3 facing = vec3(0.0), bounced = vec3(0.0);
    if (!rt_closest_hit(origin, dir, 0.0, RT_FAR, hit)) {
        if (has_dome) radiance = dome_background(dir);
    } else {
        vec3 n = rt_hit_normal(hit);
        bool back = dot(n, dir) > 0.0;
        if (back) n = -n;                    // lit on either side, as Cycles' surfaces
        vec3 x = origin + hit.t * dir;
        int m = rt_hit_material(hit);
        vec3 albedo = texelFetch(field_materials, ivec2(2 * m, 0), 0).rgb;
        vec4 emission = texelFetch(field_materials, ivec2(2 * m + 1, 0), 0);
        int sampled = int(emission.a), mesh = field_sides[hit.instance];
        bool lit_front = (mesh & 4) != 0 && (sampled & 1) != 0;
        bool lit_back = (mesh & 4) != 0 && (sampled & 2) != 0 && !((mesh & 8) != 0 && lit_front);
        radiance = (back ? lit_back : lit_front) ? vec3(0.0) : emission.rgb;
        vec3 arriving = vec3(0.0);           // irradiance x pi: albedo / pi below
        Surface s = make_surface(x, n, n, vec4(albedo, 1.0), vec4(0.0, 1.0, 0.0, 0.0));
        for (int i = 0; i < n_lights; ++i) {
            load_light(i, u_view_forward);
            vec3 diffuse, glossy;
            light_reflected(s, diffuse, glossy);
            if (max(diffuse.r, max(diffuse.g, diffuse.b)) > 0.0 && light_visible(x, n))
                radiance += diffuse;
        }
        if (u_bounce)
            bounced = albedo / FIELD_PI * field_irradiance_at(x, n, -dir);
        distance = back ? -hit.t : hit.t;
        facing = n;
    }
    imageStore(ray_image, ivec2(ray, probe), vec4(radiance, distance));
    imageStore(ray_image, ivec2(u_rays + ray, probe), vec4(facing, 0.0));
    imageStore(ray_image, ivec2(2 * u_rays + ray, probe), vec4(bounced, 0.0));
}
