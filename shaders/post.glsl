#include "lib.glsl"
// Full-screen image operations on the scene-linear HDR image (engine/gpu/passes/post.py
// and antialias.py), one per variant, each from post_src into a new target (ping-pong):
// a screen pass's body (engine/gpu/screen.py).
uniform sampler2D post_src;

#ifdef POST_SCALE
uniform float scale;          // colour: exposure 2^stops, or 1/n for an average of n
uniform float alpha_scale;    // coverage: 1, or 1/n
#endif
#ifdef POST_BLUR
uniform vec2 direction;       // (1, 0) or (0, 1): one axis of the separable Gaussian
uniform float sigma;          // pixels
#endif
#ifdef POST_MIRROR
uniform bvec2 flip;
#endif
#ifdef POST_DOWNSAMPLE
// One axis of the supersampled image's filter (engine/gpu/passes/antialias.py): tap i
// reads the sub-pixel factor * pixel + tap[i].x along `axis`, weight tap[i].y.
uniform int factor;
uniform int axis;
uniform int taps;
uniform vec2 tap[64];
#endif

// Rec. 709 luminance (the scene-linear primaries Blender uses).
const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);

#ifdef POST_FXAA
// FXAA 3.11 (Lottes), quality 12 steps, on the log of luminance: the image is scene
// linear, unbounded and of no set exposure, so edges are contrasts (ratios), and the
// result scales with the light exactly (a 1 mW and a 1 MW light give the same image
// over their power).
// Only at geometric edges: textures are already filtered (mips, anisotropy), and
// FXAA would take a texture edge lying between two pixel rows, a checker's, for a
// staircase and smear it (the demo's floor: FLIP 0.070 -> 0.097 with it everywhere).
uniform sampler2D g_depth;
uniform sampler2D g_normal;
uniform mat4 inv_view_proj;

bool geometric_edge(ivec2 px) {
    ivec2 size = textureSize(g_depth, 0);
    float d = texelFetch(g_depth, px, 0).r;
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec3 p = position_from_depth((vec2(px) + 0.5) / vec2(size), d, inv_view_proj);
    for (int i = 0; i < 9; ++i) {
        ivec2 q = clamp(px + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), size - 1);
        float dq = texelFetch(g_depth, q, 0).r;
        if (is_background(d) != is_background(dq)) return true;
        if (is_background(d)) continue;
        // Another surface: off p's tangent plane, or turned away from it.
        vec3 pq = position_from_depth((vec2(q) + 0.5) / vec2(size), dq, inv_view_proj);
        if (abs(dot(pq - p, n)) > 0.01 * length(p)) return true;
        if (dot(normalize(texelFetch(g_normal, q, 0).xyz), n) < 0.9) return true;
    }
    return false;
}

float luma_at(ivec2 p) {
    ivec2 s = textureSize(post_src, 0);
    vec3 c = texelFetch(post_src, clamp(p, ivec2(0), s - 1), 0).rgb;
    float l = max(dot(c, LUMA), 0.0);
    return log2(max(l, 1e-18));
}
// Bilinear between texels (the pooled targets are nearest-filtered), edges clamped.
vec4 fetch(vec2 uv) {
    ivec2 s = textureSize(post_src, 0);
    vec2 f = uv * vec2(s) - 0.5;
    ivec2 i = ivec2(floor(f));
    vec2 a = f - vec2(i);
    vec4 c00 = texelFetch(post_src, clamp(i, ivec2(0), s - 1), 0);
    vec4 c10 = texelFetch(post_src, clamp(i + ivec2(1, 0), ivec2(0), s - 1), 0);
    vec4 c01 = texelFetch(post_src, clamp(i + ivec2(0, 1), ivec2(0), s - 1), 0);
    vec4 c11 = texelFetch(post_src, clamp(i + ivec2(1, 1), ivec2(0), s - 1), 0);
    return mix(mix(c00, c10, a.x), mix(c01, c11, a.x), a.y);
}
// Luma between texels: the texels' lumas interpolated (as FXAA's luma channel is),
// not the luma of interpolated colour, which is not linear in it.
float luma_uv(vec2 uv) {
    vec2 f = uv * vec2(textureSize(post_src, 0)) - 0.5;
    ivec2 i = ivec2(floor(f));
    vec2 a = f - vec2(i);
    return mix(mix(luma_at(i), luma_at(i + ivec2(1, 0)), a.x),
               mix(luma_at(i + ivec2(0, 1)), luma_at(i + ivec2(1, 1)), a.x), a.y);
}
vec4 fxaa(ivec2 px) {
    if (!geometric_edge(px)) return texelFetch(post_src, px, 0);
    vec2 size = vec2(textureSize(post_src, 0));
    vec2 uv = (vec2(px) + 0.5) / size;
    vec2 texel = 1.0 / size;
    float m = luma_at(px);
    float n = luma_at(px + ivec2(0, 1)), s = luma_at(px - ivec2(0, 1));
    float e = luma_at(px + ivec2(1, 0)), w = luma_at(px - ivec2(1, 0));
    float hi = max(m, max(max(n, s), max(e, w)));
    float lo = min(m, min(min(n, s), min(e, w)));
    float range = hi - lo;
    vec4 centre = texelFetch(post_src, px, 0);
    if (range < 0.3) return centre;      // under ~23 % contrast: no edge (FXAA's high-quality threshold)
    float ne = luma_at(px + ivec2(1, 1)), nw = luma_at(px + ivec2(-1, 1));
    float se = luma_at(px + ivec2(1, -1)), sw = luma_at(px + ivec2(-1, -1));
    // Sub-pixel aliasing: how far the centre stands out from its neighbourhood.
    float average = (2.0 * (n + s + e + w) + ne + nw + se + sw) / 12.0;
    float sub = clamp(abs(average - m) / range, 0.0, 1.0);
    sub = smoothstep(0.0, 1.0, sub);
    float sub_blend = sub * sub * 0.25;   // FXAA's 'almost off' sub-pixel blend: 0.5 and 0.75 smear the corpus's straight edges and textures more than they help (measured)
    // Edge orientation.
    float horizontal = abs(nw + sw - 2.0 * w) + 2.0 * abs(n + s - 2.0 * m) + abs(ne + se - 2.0 * e);
    float vertical = abs(nw + ne - 2.0 * n) + 2.0 * abs(w + e - 2.0 * m) + abs(sw + se - 2.0 * s);
    bool is_horizontal = horizontal >= vertical;
    float l1 = is_horizontal ? s : w, l2 = is_horizontal ? n : e;
    float g1 = abs(l1 - m), g2 = abs(l2 - m);
    float step_len = is_horizontal ? texel.y : texel.x;
    float local_avg, gradient;
    if (g1 >= g2) { step_len = -step_len; local_avg = 0.5 * (l1 + m); gradient = g1; }
    else { local_avg = 0.5 * (l2 + m); gradient = g2; }
    gradient *= 0.25;
    vec2 edge_uv = uv;
    if (is_horizontal) edge_uv.y += 0.5 * step_len; else edge_uv.x += 0.5 * step_len;
    vec2 along = is_horizontal ? vec2(texel.x, 0.0) : vec2(0.0, texel.y);
    const float STEPS[12] = float[12](1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 4.0, 8.0);
    vec2 p1 = edge_uv - along, p2 = edge_uv + along;
    float d1 = luma_uv(p1) - local_avg, d2 = luma_uv(p2) - local_avg;
    bool done1 = abs(d1) >= gradient, done2 = abs(d2) >= gradient;
    for (int i = 1; i < 12 && !(done1 && done2); ++i) {
        if (!done1) { p1 -= along * STEPS[i]; d1 = luma_uv(p1) - local_avg; done1 = abs(d1) >= gradient; }
        if (!done2) { p2 += along * STEPS[i]; d2 = luma_uv(p2) - local_avg; done2 = abs(d2) >= gradient; }
    }
    float dist1 = is_horizontal ? uv.x - p1.x : uv.y - p1.y;
    float dist2 = is_horizontal ? p2.x - uv.x : p2.y - uv.y;
    bool nearer1 = dist1 < dist2;
    float span = dist1 + dist2;
    float pixel_offset = 0.5 - min(dist1, dist2) / span;
    bool centre_below = m < local_avg;
    bool good = ((nearer1 ? d1 : d2) < 0.0) != centre_below;
    // A staircase continues one row over past its end (on the centre's side); a
    // straight edge that just ends (a quad's corner) does not, and blending towards
    // its end would bend it: FXAA's known corner artefact (09_tex_wrapping_mirror:
    // FLIP 0.023 -> 0.063 without this test).
    vec2 end = nearer1 ? p1 : p2;
    vec2 across = is_horizontal ? vec2(0.0, step_len) : vec2(step_len, 0.0);
    good = good && abs(luma_uv(end - 0.5 * across) - luma_uv(end - 1.5 * across)) >= 2.0 * gradient;
    float offset = max(good ? pixel_offset : 0.0, sub_blend);
    vec2 final_uv = uv;
    if (is_horizontal) final_uv.y += offset * step_len; else final_uv.x += offset * step_len;
    return fetch(final_uv);       // alpha too: coverage and premultiplied colour blend alike
}
#endif

void screen_pixel(ivec2 px, out vec4 frag, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
#ifdef POST_SCALE
    vec4 c = texelFetch(post_src, px, 0);
    frag = vec4(c.rgb * scale, c.a * alpha_scale);
#endif
#ifdef POST_FXAA
    frag = fxaa(px);
#endif
#ifdef POST_BLUR
    // Separable Gaussian, 3 sigma each side; edges clamp.
    ivec2 size = textureSize(post_src, 0);
    int radius = int(ceil(3.0 * sigma));
    vec4 sum = vec4(0.0);
    float weight = 0.0;
    for (int i = -radius; i <= radius; ++i) {
        float w = exp(-0.5 * float(i * i) / (sigma * sigma));
        ivec2 q = clamp(px + ivec2(direction) * i, ivec2(0), size - 1);
        sum += texelFetch(post_src, q, 0) * w;
        weight += w;
    }
    frag = sum / weight;
#endif
#ifdef POST_GRAYSCALE
    vec4 c = texelFetch(post_src, px, 0);
    frag = vec4(vec3(dot(c.rgb, LUMA)), c.a);
#endif
#ifdef POST_DOWNSAMPLE
    ivec2 size = textureSize(post_src, 0);
    vec4 sum = vec4(0.0);
    for (int i = 0; i < taps; ++i) {
        ivec2 q = px;
        int o = int(tap[i].x);
        if (axis == 0) q.x = clamp(px.x * factor + o, 0, size.x - 1);
        else q.y = clamp(px.y * factor + o, 0, size.y - 1);
        sum += texelFetch(post_src, q, 0) * tap[i].y;
    }
    frag = sum;
#endif
#ifdef POST_MIRROR
    ivec2 size = textureSize(post_src, 0);
    ivec2 q = ivec2(flip.x ? size.x - 1 - px.x : px.x, flip.y ? size.y - 1 - px.y : px.y);
    frag = texelFetch(post_src, q, 0);
#endif
}
