#version 430 core
// A screen pass's compute form (engine/gpu/screen.py): one invocation a pixel runs the
// pass's body, screen_pixel in its own .glsl (the generated screen_body.glsl includes
// it), and stores its outputs into the images bound at 0 to SCREEN_OUTPUTS - 1, each
// in its texture's own format. screen.frag is the raster form of the same.
#include "screen_body.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) writeonly uniform image2D image0;
#if SCREEN_OUTPUTS > 1
layout(binding = 1) writeonly uniform image2D image1;
#endif
#if SCREEN_OUTPUTS > 2
layout(binding = 2) writeonly uniform image2D image2;
#endif
#if SCREEN_OUTPUTS > 3
layout(binding = 3) writeonly uniform image2D image3;
#endif

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(image0)))) return;
    shaded_pixel = vec2(px) + 0.5;
    vec4 o0, o1, o2, o3;
    screen_pixel(px, o0, o1, o2, o3);
    imageStore(image0, px, o0);
#if SCREEN_OUTPUTS > 1
    imageStore(image1, px, o1);
#endif
#if SCREEN_OUTPUTS > 2
    imageStore(image2, px, o2);
#endif
#if SCREEN_OUTPUTS > 3
    imageStore(image3, px, o3);
#endif
}
