// The AO search's raw values (ao.glsl, one a block of u_step x u_step pixels) blurred
// over the 4x4 tile their noise repeats on and upsampled depth-aware to pixel px, whose
// surface is at p with normal n: each raw value stands at the centre sub-pixel of its
// block and weighs by how much that sub-pixel lies on px's surface (lib.glsl
// same_surface), so nothing bleeds across edges. Shared by the occlusion's blur
// (ao_blur.glsl) and the near field's (near_field.glsl). Include after lib.glsl and
// the declarations of g_depth, g_normal and inv_view_proj.

vec4 upsampled(sampler2D raw, int u_step, ivec2 px, vec3 p, vec3 n) {
    ivec2 size = textureSize(g_depth, 0);
    vec4 sum = vec4(0.0);
    float weight = 0.0;
    ivec2 cells = textureSize(raw, 0);
    ivec2 home = px / u_step;
    for (int y = -2; y < 2; ++y) {
        for (int x = -2; x < 2; ++x) {
            ivec2 c = clamp(home + ivec2(x, y), ivec2(0), cells - 1);
            ivec2 q = min(c * u_step + u_step / 2, size - 1);
            float dq = texelFetch(g_depth, q, 0).r;
            if (is_background(dq)) continue;
            vec3 pq = position_from_depth((vec2(q) + 0.5) / vec2(size), dq, inv_view_proj);
            vec3 nq = normalize(texelFetch(g_normal, q, 0).xyz);
            float w = same_surface(p, n, pq, nq);
            sum += texelFetch(raw, c, 0) * w;
            weight += w;
        }
    }
    if (weight <= 1e-6) return texelFetch(raw, home, 0);
    return sum / weight;
}
