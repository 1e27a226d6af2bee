#version 430 core
#include "resolved.glsl"
// Counts the pixels whose resolved value holds NaN or Inf (GL 4.3+): one atomic add
// per such pixel, and those are rare, so a finite image costs one read of each texel.
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D hdr;
uniform bool transparent;
layout(std430, binding = 0) buffer Count { uint count; };
void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, textureSize(hdr, 0)))) return;
    if (not_finite(resolved(hdr, px, transparent))) atomicAdd(count, 1u);
}
