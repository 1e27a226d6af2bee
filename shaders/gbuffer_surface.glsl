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

