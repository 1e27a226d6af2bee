#version 430 core
// One mip level of the lit frame's copy from the level above it (engine/gpu/lit_copy.py):
// each texel the mean of the 2 x 2 texels it covers; an odd last row or column of the
// level above is left out, as in the 8-bit images' chains (engine/gpu/textures.py), and
// a side already 1 texel long is not halved.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) writeonly uniform image2D u_level_below;
uniform sampler2D u_lit;           // the copy; read at u_level, texel by texel
uniform int u_level;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(u_level_below)))) return;
    ivec2 last = textureSize(u_lit, u_level) - 1;
    ivec2 a = min(2 * px, last), b = min(2 * px + 1, last);
    vec4 sum = texelFetch(u_lit, a, u_level) + texelFetch(u_lit, ivec2(b.x, a.y), u_level) +
               texelFetch(u_lit, ivec2(a.x, b.y), u_level) + texelFetch(u_lit, b, u_level);
    imageStore(u_level_below, px, 0.25 * sum);
}
