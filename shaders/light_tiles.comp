#version 430 core
#include "lib.glsl"
#include "clusters.glsl"
// One work group a tile: the view-depth range of the surfaces it shows and which of
// its slices hold one (clusters.glsl), for light_cull.comp. A tile showing nothing
// gets no slice, so its clusters list nothing.
layout(local_size_x = TILE, local_size_y = TILE) in;
uniform sampler2D g_depth;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;

shared uint z_lo;
shared uint z_hi;
shared uint bits;

// Floats as uints of the same order, for atomicMin/atomicMax.
uint ordered(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float unordered(uint u) {
    return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7FFFFFFFu : ~u);
}

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        z_lo = 0xFFFFFFFFu;
        z_hi = 0u;
        bits = 0u;
    }
    barrier();
    ivec2 size = textureSize(g_depth, 0);
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    bool surface = false;
    float z = 0.0;
    if (all(lessThan(px, size))) {
        float depth = texelFetch(g_depth, px, 0).r;
        if (!is_background(depth)) {
            vec2 uv = (vec2(px) + 0.5) / vec2(size);
            z = dot(position_from_depth(uv, depth, inv_view_proj), cam_forward);
            surface = true;
            atomicMin(z_lo, ordered(z));
            atomicMax(z_hi, ordered(z));
        }
    }
    barrier();
    vec2 b = vec2(unordered(z_lo), unordered(z_hi));
    if (surface) atomicOr(bits, 1u << uint(slice_of(z, b)));
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        int t = int(gl_WorkGroupID.y) * cluster_tiles.x + int(gl_WorkGroupID.x);
        tile_bounds[t] = bits == 0u ? vec4(0.0) : vec4(b, uintBitsToFloat(bits), 1.0);
    }
}
