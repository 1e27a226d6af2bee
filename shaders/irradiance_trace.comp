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
// Hits take the lights' diffuse light alone (field_hits.glsl): an area light's glossy
// lobes, integrated over its polygon, would be computed and dropped.
#define LIGHTS_DIFFUSE_ONLY
#include "lights.glsl"
#include "environment.glsl"
#include "raytrace.glsl"
#include "irradiance_field.glsl"
layout(local_size_x = 64) in;
// x ray, y probe: (the radiance the field does not bring, signed distance); x u_rays +
// ray: the hit's normal, towards the probe (0 where the ray escaped); x 2 u_rays + ray:
// the radiance the field brings (its bounces so far)
layout(rgba32f, binding = 0) writeonly uniform image2D ray_image;
uniform mat3 u_rotation;
uniform int u_rays;                  // a probe's
uniform int u_first_probe;           // the first probe of those this dispatch updates
#include "field_hits.glsl"

void main() {
    int probe = u_first_probe + int(gl_WorkGroupID.y);
    int ray = int(gl_WorkGroupID.x) * 64 + int(gl_LocalInvocationID.x);
    if (ray >= u_rays) return;
    // The first update starts from probes at their grid places, on.
    vec4 state = u_bounce ? probe_state(probe) : vec4(0.0, 0.0, 0.0, 1.0);
    int g = probe_grid(probe);
    vec3 origin = probe_position(g, probe_cell(g, probe), state);
    vec3 dir = fibonacci_ray(ray, u_rays, u_rotation);
    vec3 bounced, facing;
    float distance;
    vec3 radiance = traced_radiance(origin, dir, false, bounced, distance, facing);
    imageStore(ray_image, ivec2(ray, probe), vec4(radiance, distance));
    imageStore(ray_image, ivec2(u_rays + ray, probe), vec4(facing, 0.0));
    imageStore(ray_image, ivec2(2 * u_rays + ray, probe), vec4(bounced, 0.0));
}
