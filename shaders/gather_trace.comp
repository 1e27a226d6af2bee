#version 430 core
// The final gather's rays (engine/gpu/passes/near_field.py, a still's): the diffuse
// bounce at each block of u_step x u_step pixels gathered by rays from the surface seen
// at its centre sub-pixel, in place of the irradiance field's coarse light, so that it
// sees what the probes cannot resolve and the screen does not show (the floor under a
// table, the faces a box turns to the floor's light). One invocation a ray, as the
// field's probes trace theirs (irradiance_trace.comp): u_gather_rays rays a block spread
// over its hemisphere by the cosine, each shaded as a probe's (field_hits.glsl
// traced_radiance: the hit's emission, the lights seen by shadow rays, the field of one
// bounce fewer, glass passed through; the dome where a ray escapes), so the pixel gets
// the scene's bounces. gather_mean.glsl takes each block's mean.
#include "lib.glsl"
// Hits take the lights' diffuse light alone (field_hits.glsl): an area light's glossy
// lobes, integrated over its polygon, would be computed and dropped.
#define LIGHTS_DIFFUSE_ONLY
#include "lights.glsl"
#include "environment.glsl"
#include "raytrace.glsl"
#include "irradiance_field.glsl"
#include "field_hits.glsl"
layout(local_size_x = 64) in;
// x block.x * u_gather_rays + ray, y block.y: (radiance, 1), or 0 where the block's
// centre sees the background.
layout(rgba32f, binding = 0) writeonly uniform image2D ray_image;
uniform sampler2D g_depth;
uniform sampler2D g_normal;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;
uniform int u_step;
uniform int u_gather_rays;
uniform ivec2 u_blocks;

void main() {
    int column = int(gl_GlobalInvocationID.x);
    ivec2 block = ivec2(column / u_gather_rays, gl_GlobalInvocationID.y);
    int ray = column - block.x * u_gather_rays;
    if (block.x >= u_blocks.x || block.y >= u_blocks.y) return;
    ivec2 at = ivec2(column, block.y);
    ivec2 size = textureSize(g_depth, 0);
    ivec2 px = min(block * u_step + u_step / 2, size - 1);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) {
        imageStore(ray_image, at, vec4(0.0));
        return;
    }
    vec3 p = position_from_depth((vec2(px) + 0.5) / vec2(size), depth, inv_view_proj);
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    // The side the camera sees: a surface seen from behind (inside a closed emitter, a
    // single-sided wall's back) gathers over its own hemisphere, as it is shaded.
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    if (dot(n, v) < 0.0) n = -n;
    // Pulled towards the camera, as the contact rays start (raytrace.glsl
    // rt_seen_origin): a position rebuilt from depth may lie a little behind its surface,
    // and a ray from there would start past a wall (a sealed room's floor by its wall saw
    // the sun outside).
    vec3 x = rt_seen_origin(p, field_eye) + n * u_epsilon;
    vec3 t = normalize(abs(n.z) < 0.999 ? cross(n, vec3(0.0, 0.0, 1.0)) : cross(n, vec3(1.0, 0.0, 0.0)));
    vec3 b = cross(n, t);
    // Stratified over the unit disc's area (Malley: the cosine), turned per block by a
    // Bayer index (lib.glsl): neighbouring blocks turn their rays apart, so the
    // upsampling's 4x4 blur (ao_upsample.glsl) averages 16 turns.
    float turn = (float(bayer4(uvec2(block))) + 0.5) / 16.0;
    float shift = (float(bayer4(uvec2(block.yx + ivec2(1, 2)))) + 0.5) / 16.0;
    float u = (float(ray) + shift) / float(u_gather_rays);
    float phi = 2.0 * PI * fract(float(ray) * 0.6180339887498949 + turn);
    float r = sqrt(u);
    vec3 dir = t * (r * cos(phi)) + b * (r * sin(phi)) + n * sqrt(max(1.0 - u, 0.0));
    vec3 bounced, facing;
    float distance;
    vec3 radiance = traced_radiance(x, dir, true, bounced, distance, facing);
    imageStore(ray_image, at, vec4(radiance + bounced, 1.0));
}
