#include "lib.glsl"
#include "gbuffer_surface.glsl"
#include "lights.glsl"
#include "shadow_lookup.glsl"
// An area light's shadow, per pixel, for its filter (engine/gpu/passes/area_visibility.py):
// the visible fraction of the light (shadow_lookup.glsl area_shadow_factor), its taps
// interleaved over 4 x 4 pixel blocks (AREA_INTERLEAVED: the 16 pixels of a block take
// 16 offsets of the light's lattice), so the depth-aware 4 x 4 blur that follows
// (area_visibility_blur.glsl) averages 16 times the taps a pixel takes; y: the
// penumbra's width, which bounds that blur. Background: 1.
uniform int light_index;

void screen_pixel(ivec2 px, out vec4 visibility, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
#ifdef COMPUTE
    shaded_pixel = vec2(px) + 0.5;
#endif
    visibility = vec4(1.0, 0.0, 0.0, 0.0);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) return;
    load_light(light_index, cam_forward);
    Surface s = gbuffer_surface(px, depth);
    visibility.x = light_shadow(s.p, s.n, dot(s.p, cam_forward));
    visibility.y = area_penumbra;
}
