#include "lib.glsl"
#include "environment.glsl"
// Full screen, once: the dome's light (environment.glsl dome_light: harmonics for
// diffuse, the prefiltered cube and the split-sum table for the specular lobe and the
// coat), emission, and the dome as the background where nothing was drawn. Ambient
// occlusion (HAS_AO) dims the dome's diffuse light, and its specular occlusion the
// dome's reflections (ao.glsl); it never touches emission or the lights. The surface
// is read from the G-buffer as the light passes read it (gbuffer_surface.glsl).
#include "gbuffer_surface.glsl"
#ifdef IRRADIANCE_FIELD
#include "irradiance_field.glsl"
uniform vec3 field_eye;         // the camera's world position: s.p is relative to it
#endif
uniform bool transparent;
#if defined(HAS_AO) && !defined(BASE_OCCLUSION)    // gbuffer_surface.glsl declares it then
uniform sampler2D ao_tex;
#endif

// A screen pass's body (engine/gpu/screen.py): the HDR image and, with WRITE_AOVS,
// the render passes (engine/gpu/passes/ambient.py): the diffuse light (the dome's,
// DiffDir, or under the field the field's, which the pass stores as DiffInd), the
// glossy light (added to by the light pass) and the background.
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
        Surface s = gbuffer_surface(px, depth);
        emitted = texelFetch(g_emit, px, 0).rgb;
        vec2 occlusion = vec2(1.0);         // ambient occlusion, specular occlusion: ao.glsl
#ifdef HAS_AO
        occlusion = texelFetch(ao_tex, px, 0).xy;
#endif
        dome_light(s, occlusion, diffuse, glossy);
#ifdef IRRADIANCE_FIELD
        // The field's light in place of the dome's diffuse light (which it holds).
        vec3 E = field_irradiance_at(s.p + field_eye, s.n, s.v);
        diffuse = brdf_diffuse(s) * E * bump_dome(s);
#ifdef SHEEN
        diffuse += sheen_ambient(s, E);
#endif
#endif
    }
    // Alpha: coverage (resolve.frag), averaged by anti-aliasing.
    frag = vec4(diffuse + glossy + background + emitted, is_background(depth) ? 0.0 : 1.0);
#ifdef WRITE_AOVS
    aov_diffuse = vec4(diffuse, 0.0);
    aov_glossy = vec4(glossy, 0.0);
    aov_env = vec4(background, 0.0);
#endif
}
