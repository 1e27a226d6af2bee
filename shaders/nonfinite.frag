#version 330 core
#include "resolved.glsl"
// The GL 3.3 count of non-finite pixels: drawn with colour writes off inside an
// occlusion query, only the pixels holding NaN or Inf pass, so the query's sample
// count is the pixel count.
uniform sampler2D hdr;
uniform bool transparent;
out vec4 frag;
void main() {
    vec4 c = resolved(hdr, ivec2(gl_FragCoord.xy), transparent);
    if (!not_finite(c)) discard;
    frag = c;
}
