#include "lib.glsl"
#include "resolved.glsl"
// HDR accumulation -> the output image, in the row order it is read back in: top row
// first for numpy (`top_down`), GL's bottom-up for Blender, so no copy flips it. NaN
// and Inf are passed on as they are: the resolve pass counts them and names the prims
// they lie on. A screen pass's body (engine/gpu/screen.py); its compute form counts
// the pixels holding NaN or Inf as it writes them (the raster form leaves that to
// engine/gpu/readback.py), so the count is of exactly the values read back.
uniform sampler2D hdr;
uniform bool transparent;
uniform bool top_down;
#ifdef COMPUTE
layout(std430, binding = 0) buffer Count { uint nonfinite; };
#endif

void screen_pixel(ivec2 px, out vec4 frag, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
    if (top_down) px.y = textureSize(hdr, 0).y - 1 - px.y;
    frag = resolved(hdr, px, transparent);
#ifdef COMPUTE
    if (not_finite(frag)) atomicAdd(nonfinite, 1u);
#endif
}
