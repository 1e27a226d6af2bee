#include "lib.glsl"
// The final gather's blocks (engine/gpu/passes/near_field.py): each block's rays
// (gather_trace.comp) averaged into the near field's raw form, as ao.glsl's NEAR_FIELD
// search gives it: (the irradiance gathered, the share of the hemisphere it stands for:
// all of it), which the composite (near_field.glsl) takes in place of the field's light.
uniform sampler2D u_gather_rays_tex;
uniform int u_gather_rays;

void screen_pixel(ivec2 block, out vec4 near, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
    vec4 sum = vec4(0.0);
    for (int i = 0; i < u_gather_rays; ++i)
        sum += texelFetch(u_gather_rays_tex, ivec2(block.x * u_gather_rays + i, block.y), 0);
    // Irradiance: pi x the radiance's mean over cosine-distributed rays; nothing where
    // the block's centre sees the background (the field's light stays).
    near = sum.w > 0.0 ? vec4(PI * sum.rgb / sum.w, 1.0) : vec4(0.0);
}
