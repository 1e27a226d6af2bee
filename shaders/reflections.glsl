// The glossy bounce (engine/gpu/passes/reflections.py): the base lobe's reflection of the
// lit scene in place of the dome's, over the lit opaque frame. The ambient pass left out
// the dome's reflection (GLOSSY_BOUNCE: spec x dome_specular(lobe) x the specular
// occlusion); this adds spec x L, spec the same split-sum albedo, so energy stays as the
// dome's had it.
// L, by the roughness, mixes
//   near  the ray along the lobe's dominant direction, traced (raytrace.glsl): where it
//         meets a surface shown on screen and not hidden, the lit frame there, at the mip
//         level of the lobe's cone's footprint; where it escapes, the dome over the lobe;
//         where its hit is off screen or hidden, `far`;
//   far   the irradiance field's irradiance along that direction over pi (a cosine lobe's
//         mean radiance: the field as prefiltered radiance, as Majercik et al. 2021 read
//         it for rough reflections), the dome's reflection where there is no field.
// The coat keeps the dome's reflection.
// The render passes (WRITE_AOVS) split the change as Cycles splits light: the dome, met
// by a ray that escapes or read as the dome's reflection where there is no field, is
// direct light (GlossDir, added to in place); what the ray meets in the lit frame and
// the field's light, which has bounced, are GlossInd.
#include "lib.glsl"
#include "raytrace.glsl"
#include "environment.glsl"
#include "gbuffer_surface.glsl"
#ifdef IRRADIANCE_FIELD
#include "irradiance_field.glsl"
#endif
#if defined(HAS_AO) && !defined(BASE_OCCLUSION)    // gbuffer_surface.glsl declares it then
uniform sampler2D ao_tex;
#endif
uniform mat4 view_proj;         // camera-relative -> clip
uniform vec3 u_eye;             // the camera's world position (the tracer's frame)
uniform sampler2D u_lit;        // the lit opaque frame, mip-mapped (lit_copy.py)
uniform float u_lit_lods;       // its coarsest mip level
#ifdef WRITE_AOVS
uniform sampler2D u_glossy;     // the GlossDir render pass so far (passes/ambient.py)
#endif
#include "lit_frame.glsl"

// Roughness from which the field's reflection takes over from the traced one, and at
// which it is all of it: one ray, blurred by the cone's mip level, stands for a lobe
// only while the lobe is narrow (docs/rendering.md, "Glossy bounce").
#define ROUGH_FROM 0.25
#define ROUGH_TO 0.45
// The least distance a ray goes from its surface, relative to its distance from the
// camera (the position comes from depth), and off it along the normal.
#define REFLECT_OFFSET 1.0e-3

// The lit frame where camera-relative point h, at distance t along ray d, is seen,
// blurred over the footprint of a cone of half-angle `cone` about d.
vec3 lit_at(vec2 uv, vec3 h, vec3 d, float t, float cone) {
    vec3 across = cross(h, d);
    if (dot(across, across) < 1.0e-12) across = cross(h, vec3(0.0, 0.0, 1.0) + 0.5 * d.yzx);
    vec2 edge;
    on_screen(h + normalize(across) * t * tan(min(cone, 1.5)), edge);
    float pixels = length((edge - uv) * vec2(textureSize(u_lit, 0)));
    return textureLod(u_lit, uv, clamp(log2(max(pixels, 1.0)), 0.0, u_lit_lods)).rgb;
}

// The reflection along the ray from camera-relative p (normal n) in direction d, of a
// lobe with cone half-angle `cone`; `escaped`: the dome over the lobe; `far`: what an
// off-screen or hidden hit takes. `dome`: whether what it returns is the dome's light
// (`far_dome`: whether `far` is).
vec3 traced_reflection(vec3 p, vec3 n, vec3 d, float cone, vec3 escaped, vec3 far,
                       bool far_dome, out bool dome) {
    float scale = 1.0 + length(p);
    vec3 o = p + n * REFLECT_OFFSET * scale;
    vec2 uv;
    float t;
    int met = frame_hit(o, d, REFLECT_OFFSET * scale, g_depth, uv, t);
    dome = met == FRAME_ESCAPED || (met != FRAME_SHOWN && far_dome);
    if (met == FRAME_ESCAPED) return escaped;
    return met == FRAME_SHOWN ? lit_at(uv, o + t * d, d, t, cone) : far;
}

// A screen pass's body (engine/gpu/screen.py), compute form only: the lit frame with
// the base lobe's reflection of the scene in place of the dome's; with WRITE_AOVS the
// change's direct light added to the GlossDir render pass, and its indirect light the
// GlossInd pass.
void screen_pixel(ivec2 px, out vec4 frag, out vec4 aov_glossy, out vec4 aov_glossy_indirect,
                  out vec4 unused3) {
    aov_glossy = aov_glossy_indirect = unused3 = vec4(0.0);
#ifdef WRITE_AOVS
    // Its own texel, read before this invocation stores it: the change goes to GlossDir
    // too, so the render passes still add up to the image.
    aov_glossy = texelFetch(u_glossy, px, 0);
#endif
    frag = texelFetch(u_lit, px, 0);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) return;
    Surface s = gbuffer_surface(px, depth);
    vec3 spec = s.under_coat * s.spec_albedo;
    if (max(spec.r, max(spec.g, spec.b)) <= 0.0) return;
    float specular_occlusion = 1.0;
#ifdef HAS_AO
    specular_occlusion = texelFetch(ao_tex, px, 0).y;
#endif
    Lobe lobe = make_lobe(s.n, s.v, s.roughness, s.spec_dielectric);
    vec3 dome = has_dome ? dome_specular(lobe) : vec3(0.0);
    vec3 d = normalize(specular_dominant(s.n, s.v, s.roughness));
#ifdef IRRADIANCE_FIELD
    vec3 far = field_irradiance_along(s.p + u_eye, s.n, s.v, d) / PI;
    bool far_dome = false;
#else
    vec3 far = dome * specular_occlusion;
    bool far_dome = true;
#endif
    float rough = smoothstep(ROUGH_FROM, ROUGH_TO, s.roughness);
    bool near_dome = far_dome;
    vec3 near = rough < 1.0 ?
        traced_reflection(s.p, s.n, d, lobe_cone(lobe), dome, far, far_dome, near_dome) : far;
    vec3 change = spec * mix(near, far, rough);
    frag.rgb += change;
    vec3 direct = spec * mix(near_dome ? near : vec3(0.0), far_dome ? far : vec3(0.0), rough);
    aov_glossy.rgb += direct;
    aov_glossy_indirect.rgb = spec * mix(near_dome ? vec3(0.0) : near,
                                         far_dome ? vec3(0.0) : far, rough);
}
