#version 330 core
#include "lib.glsl"
// HDR accumulation -> float32 output. Alpha is 1, or, when transparent, the opaque
// coverage combined with the blended layers' alpha the transparency pass left in the
// HDR target's alpha (1 - prod(1 - alpha); 0 without blended surfaces).
uniform sampler2D hdr;
uniform sampler2D g_depth;
uniform bool transparent;
out vec4 frag;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 h = texelFetch(hdr, px, 0);
    vec3 c = h.rgb;
    // Lights summing past float16's range overflow to +Inf: that is "very bright".
    c = mix(c, vec3(65504.0), bvec3(isinf(c.r) && c.r > 0.0, isinf(c.g) && c.g > 0.0,
                                    isinf(c.b) && c.b > 0.0));
    c = finite(c);
    float coverage = is_background(texelFetch(g_depth, px, 0).r) ? 0.0 : 1.0;
    float alpha = 1.0 - (1.0 - coverage) * (1.0 - clamp(h.a, 0.0, 1.0));
    frag = vec4(c, transparent ? alpha : 1.0);
}
