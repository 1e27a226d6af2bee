#include "lib.glsl"
// Depth-aware (bilateral) blur of the raw occlusion over the 4x4 tile its noise
// repeats on (ao.glsl): neighbours on another surface (depth off the centre's plane
// by more than a few percent, or a normal turned away) weigh nothing, so occlusion
// never bleeds across edges. When the occlusion was drawn at 1/u_step of the size,
// this is also its depth-aware upsampling: each raw value stands at the centre
// sub-pixel of its block, and is weighed by that sub-pixel's surface. The specular
// occlusion (ao.glsl) is blurred alike: (occlusion, specular occlusion) out.
uniform sampler2D ao_tex;      // raw occlusion
uniform int u_step;
uniform sampler2D g_depth;
uniform sampler2D g_normal;
uniform mat4 inv_view_proj;
#include "ao_upsample.glsl"

// A screen pass's body (engine/gpu/screen.py): outputs the occlusion and, with
// WRITE_AOV, the AO render pass (grey).
void screen_pixel(ivec2 px, out vec4 ao, out vec4 aov_ao, out vec4 unused2,
                  out vec4 unused3) {
    aov_ao = unused2 = unused3 = vec4(0.0);
    ivec2 size = textureSize(g_depth, 0);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) {
        ao = vec4(1.0, 1.0, 0.0, 0.0);
#ifdef WRITE_AOV
        aov_ao = vec4(1.0);
#endif
        return;
    }
    vec3 p = position_from_depth((vec2(px) + 0.5) / vec2(size), depth, inv_view_proj);
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec4 raw = upsampled(ao_tex, u_step, px, p, n);
    ao = vec4(clamp(raw.x, 0.0, 1.0), clamp(raw.y, 0.0, 1.0), 0.0, 0.0);
#ifdef WRITE_AOV
    aov_ao = vec4(vec3(ao.x), 1.0);
#endif
}
