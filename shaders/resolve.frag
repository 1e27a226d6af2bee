#version 330 core
#include "lib.glsl"
// HDR accumulation -> float32 output. Alpha is 1, or coverage when transparent (the
// HDR target's alpha: the ambient pass writes 1 where a surface was drawn, and the
// transparency pass composites blended layers over it, alpha too).
uniform sampler2D hdr;
uniform bool transparent;
out vec4 frag;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 light = texelFetch(hdr, px, 0);
    vec3 c = light.rgb;
    // Lights summing past float16's range overflow to +Inf: that is "very bright".
    c = mix(c, vec3(65504.0), bvec3(isinf(c.r) && c.r > 0.0, isinf(c.g) && c.g > 0.0,
                                    isinf(c.b) && c.b > 0.0));
    c = finite(c);
    float coverage = clamp(light.a, 0.0, 1.0);
    frag = vec4(c, transparent ? coverage : 1.0);
}
