#version 330 core
#include "resolved.glsl"
// HDR accumulation -> the output image, in the row order it is read back in: top row
// first for numpy (`top_down`), GL's bottom-up for Blender, so no copy flips it. NaN
// and Inf are passed on as they are: the resolve pass counts them and names the prims
// they lie on.
uniform sampler2D hdr;
uniform bool transparent;
uniform bool top_down;
out vec4 frag;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (top_down) px.y = textureSize(hdr, 0).y - 1 - px.y;
    frag = resolved(hdr, px, transparent);
}
