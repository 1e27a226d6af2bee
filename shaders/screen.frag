#version 330 core
// A screen pass's raster form (engine/gpu/screen.py): one full-screen triangle
// (fullscreen.vert) runs the pass's body, screen_pixel in its own .glsl (the
// generated screen_body.glsl includes it), at each fragment, its outputs into the
// framebuffer's SCREEN_OUTPUTS targets. screen.comp is the compute form of the same.
#include "screen_body.glsl"
layout(location = 0) out vec4 frag0;
#if SCREEN_OUTPUTS > 1
layout(location = 1) out vec4 frag1;
#endif
#if SCREEN_OUTPUTS > 2
layout(location = 2) out vec4 frag2;
#endif
#if SCREEN_OUTPUTS > 3
layout(location = 3) out vec4 frag3;
#endif

void main() {
    vec4 o0, o1, o2, o3;
    screen_pixel(ivec2(gl_FragCoord.xy), o0, o1, o2, o3);
    frag0 = o0;
#if SCREEN_OUTPUTS > 1
    frag1 = o1;
#endif
#if SCREEN_OUTPUTS > 2
    frag2 = o2;
#endif
#if SCREEN_OUTPUTS > 3
    frag3 = o3;
#endif
}
