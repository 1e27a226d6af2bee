#version 330 core
#include "lib.glsl"
// HDR accumulation -> float32 output. Alpha is 1, or coverage when transparent.
// NaN and Inf are passed on as they are: the resolve pass counts them and names the
// prims they lie on.
uniform sampler2D hdr;
uniform sampler2D g_depth;
uniform bool transparent;
out vec4 frag;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 c = texelFetch(hdr, px, 0).rgb;
    float coverage = is_background(texelFetch(g_depth, px, 0).r) ? 0.0 : 1.0;
    frag = vec4(c, transparent ? coverage : 1.0);
}
