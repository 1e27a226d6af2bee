// A pixel's shading point read back from the G-buffer, as every screen-space lighting
// pass reads it (the light volumes, the clustered lights): its camera-relative position
// (lib.glsl: the viewer at the origin), normals, material and layers. Include after
// lib.glsl; the pass binds the G-buffer and the camera (passes/ambient.py bind_gbuffer).
uniform sampler2D g_base;
uniform sampler2D g_normal;
uniform sampler2D g_mat;
uniform sampler2D g_depth;
uniform sampler2D g_emit;       // .a: the pixel's base colour takes the occlusion
#ifdef BASE_OCCLUSION
uniform sampler2D ao_tex;
#endif
#ifdef SHEEN
uniform sampler2D g_sheen;      // the sheen lobe (passes/gbuffer.py), sheen.glsl apply_sheen
#endif
#ifdef BUMP_CORRECTION
uniform sampler2D g_smooth;     // the normals before the normal maps
#endif
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;

// The surface at pixel px, whose stored depth `depth` is not the background's.
Surface gbuffer_surface(ivec2 px, float depth) {
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    vec3 p = position_from_depth(uv, depth, inv_view_proj);
    vec4 nrm = texelFetch(g_normal, px, 0);
    vec3 n = normalize(nrm.xyz);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    vec4 base = texelFetch(g_base, px, 0);
#ifdef BASE_OCCLUSION
    // An Ambient Occlusion node's Color on Base Color: Cycles darkens the albedo itself.
    base.rgb *= mix(1.0, texelFetch(ao_tex, px, 0).r, texelFetch(g_emit, px, 0).a);
#endif
    Surface s = make_surface(p, n, v, base, texelFetch(g_mat, px, 0), nrm.w);
#ifdef BUMP_CORRECTION
    s.smooth_n = normalize(texelFetch(g_smooth, px, 0).xyz);
#endif
#ifdef SHEEN
    apply_sheen(s, texelFetch(g_sheen, px, 0));
#endif
    return s;
}


// The geometric normal at pixel px (camera-relative point p, shading normal n), facing
// the side n faces, from its neighbours' points: on each axis the side whose next two
// pixels continue p's surface best (the nearest to a line with p), so that a
// pixel at a crease or a silhouette takes its own surface's side; n where no side on
// an axis is flat (a crease on one side, the image's edge or the sky on the other).
// Shadows' contact test takes the surface's plane from it (shadow_lookup.glsl).
vec3 gbuffer_point(ivec2 q, ivec2 size, out bool ok) {
    float d = texelFetch(g_depth, clamp(q, ivec2(0), size - 1), 0).r;
    ok = !is_background(d) && all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, size));
    return position_from_depth((vec2(q) + 0.5) / vec2(size), d, inv_view_proj);
}

vec3 gbuffer_geometric_normal(ivec2 px, vec3 p, vec3 n) {
    ivec2 size = textureSize(g_depth, 0);
    vec3 axes[2];
    for (int a = 0; a < 2; ++a) {
        axes[a] = vec3(0.0);
        float best = 1e30;
        ivec2 step = a == 0 ? ivec2(1, 0) : ivec2(0, 1);
        for (int side = -1; side <= 1; side += 2) {
            bool ok1, ok2;
            vec3 p1 = gbuffer_point(px + side * step, size, ok1);
            vec3 p2 = gbuffer_point(px + 2 * side * step, size, ok2);
            if (!ok1) continue;
            // How far p2 falls off the line through p and p1 (a plane's points along a
            // row of pixels lie on a line), over the step: flat at a tenth at most.
            vec3 step1 = p1 - p;
            float off = ok2 ? length(cross(p2 - p, step1)) / max(dot(step1, step1), 1e-30)
                            : 1e30;
            if (off < min(best, 0.1)) {
                best = off;
                axes[a] = (p1 - p) * float(side);
            }
        }
    }
    vec3 g = cross(axes[0], axes[1]);
    if (dot(g, g) <= 0.0) return n;
    g = normalize(g);
    return dot(g, n) < 0.0 ? -g : g;
}
