#include "lib.glsl"
#include "environment.glsl"
// Full screen, once: the dome's light (environment.glsl dome_light: harmonics for
// diffuse, the prefiltered cube and the split-sum table for the specular lobe and the
// coat), emission, and the dome as the background where nothing was drawn. Ambient
// occlusion (HAS_AO) dims the dome's diffuse light, and its specular occlusion the
// dome's reflections (ao.glsl); it never touches emission or the lights. Positions are camera-relative (lib.glsl):
// the viewer is at the origin.
uniform sampler2D g_base;
uniform sampler2D g_normal;
uniform sampler2D g_mat;
uniform sampler2D g_emit;
uniform sampler2D g_depth;
#ifdef SHEEN
uniform sampler2D g_sheen;      // the sheen lobe (passes/gbuffer.py), sheen.glsl apply_sheen
#endif
#ifdef BUMP_CORRECTION
uniform sampler2D g_smooth;     // the normals before the normal maps (lib.glsl bump_dome)
#endif
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;

uniform bool transparent;
#ifdef HAS_AO
uniform sampler2D ao_tex;
#endif


// A screen pass's body (engine/gpu/screen.py): the HDR image and, with WRITE_AOVS,
// the render passes (engine/gpu/passes/ambient.py): the dome's diffuse and glossy
// light (added to by the light pass) and the background.
void screen_pixel(ivec2 px, out vec4 frag, out vec4 aov_diffuse, out vec4 aov_glossy,
                  out vec4 aov_env) {
    aov_diffuse = aov_glossy = aov_env = vec4(0.0);
    float depth = texelFetch(g_depth, px, 0).r;
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    vec3 diffuse = vec3(0.0), glossy = vec3(0.0), background = vec3(0.0), emitted = vec3(0.0);
    if (is_background(depth)) {
        if (has_dome && !transparent)
            background = dome_background(pixel_ray(uv, inv_view_proj, cam_ortho, cam_forward));
    } else {
        vec3 p = position_from_depth(uv, depth, inv_view_proj);
        vec4 nrm = texelFetch(g_normal, px, 0);
        vec3 n = normalize(nrm.xyz);
        vec3 v = cam_ortho ? -cam_forward : normalize(-p);
        vec4 base = texelFetch(g_base, px, 0);
#ifdef BASE_OCCLUSION
        // An Ambient Occlusion node's Color on Base Color (g_emit.a marks it): the albedo
        // darkened as Cycles darkens it, on top of the dome's own occlusion below.
        base.rgb *= mix(1.0, texelFetch(ao_tex, px, 0).r, texelFetch(g_emit, px, 0).a);
#endif
        Surface s = make_surface(p, n, v, base, texelFetch(g_mat, px, 0), nrm.w);
#ifdef BUMP_CORRECTION
        s.smooth_n = normalize(texelFetch(g_smooth, px, 0).xyz);
#endif
#ifdef SHEEN
        apply_sheen(s, texelFetch(g_sheen, px, 0));
#endif
        emitted = texelFetch(g_emit, px, 0).rgb;
        vec2 occlusion = vec2(1.0);         // ambient occlusion, specular occlusion: ao.glsl
#ifdef HAS_AO
        occlusion = texelFetch(ao_tex, px, 0).xy;
#endif
        dome_light(s, occlusion, diffuse, glossy);
    }
    // Alpha: coverage (resolve.frag), averaged by anti-aliasing.
    frag = vec4(diffuse + glossy + background + emitted, is_background(depth) ? 0.0 : 1.0);
#ifdef WRITE_AOVS
    aov_diffuse = vec4(diffuse, 0.0);
    aov_glossy = vec4(glossy, 0.0);
    aov_env = vec4(background, 0.0);
#endif
}
