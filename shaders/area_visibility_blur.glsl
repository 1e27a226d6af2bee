#include "lib.glsl"
// The area light's visibility (area_visibility.glsl) averaged over the 4 x 4 block its
// taps interleave on, depth-aware (lib.glsl same_surface), and no wider than its
// penumbra: each neighbour weighs a Gaussian of its distance with sigma half the
// penumbra's width in pixels (area_penumbra: the blocker search's, or the march's),
// so a contact shadow a pixel or two wide keeps its edge, and a wide penumbra
// averages all 16 sets of taps.
uniform sampler2D visibility_tex;  // x: visibility, y: the penumbra's width (world)
uniform sampler2D g_depth;
uniform sampler2D g_normal;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;
uniform float pixel_scale;         // pixels per world unit at view depth 1 (or anywhere: ortho)
// Neighbours whose visibility differs from the pixel's by much more than the noise of
// its taps (a binomial's: sqrt(v (1 - v) / taps)) weigh little: the edge of a shadow
// the width estimate misses (a contact) stays; the dither within a penumbra does not.
uniform float taps;
const float NOISE_SPREAD = 2.5;

void screen_pixel(ivec2 px, out vec4 visibility, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
    vec4 own = texelFetch(visibility_tex, px, 0);
    visibility = vec4(own.x, 0.0, 0.0, 0.0);
    ivec2 size = textureSize(g_depth, 0);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth) || own.y <= 0.0) return;
    vec3 p = position_from_depth((vec2(px) + 0.5) / vec2(size), depth, inv_view_proj);
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    float width = own.y * pixel_scale / (cam_ortho ? 1.0 : max(dot(p, cam_forward), 1e-6));
    float sigma = 0.5 * width;
    if (sigma < 0.25) return;
    float sum = 0.0, weight = 0.0;
    for (int y = -2; y < 2; ++y) {
        for (int x = -2; x < 2; ++x) {
            ivec2 q = clamp(px + ivec2(x, y), ivec2(0), size - 1);
            float dq = texelFetch(g_depth, q, 0).r;
            if (is_background(dq)) continue;
            vec3 pq = position_from_depth((vec2(q) + 0.5) / vec2(size), dq, inv_view_proj);
            vec3 nq = normalize(texelFetch(g_normal, q, 0).xyz);
            float d2 = float(x * x + y * y);
            float v = texelFetch(visibility_tex, q, 0).x;
            float noise = sqrt(max(max(v * (1.0 - v), own.x * (1.0 - own.x)), 0.0) / taps);
            float dv = (v - own.x) / (NOISE_SPREAD * noise + 1e-3);
            float w = same_surface(p, n, pq, nq) * exp(-d2 / (2.0 * sigma * sigma) - 0.5 * dv * dv);
            sum += v * w;
            weight += w;
        }
    }
    if (weight > 1e-6) visibility.x = clamp(sum / weight, 0.0, 1.0);
}
