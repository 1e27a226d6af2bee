#version 330 core
#include "lib.glsl"
// HDR accumulation -> float32 output. Alpha is 1, or coverage when transparent (the
// HDR target's alpha: the ambient pass writes 1 where a surface was drawn, the
// transparency pass composites blended layers over it, alpha too, and anti-aliasing
// filters it). NaN and Inf are passed on as they are: the resolve pass counts them and
// names the prims they lie on.
uniform sampler2D hdr;
uniform bool transparent;
out vec4 frag;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 light = texelFetch(hdr, px, 0);
    vec3 c = light.rgb;
    float coverage = clamp(light.a, 0.0, 1.0);
    frag = vec4(c, transparent ? coverage : 1.0);
}
