#include "lib.glsl"
#include "environment.glsl"
// The near field's composite (passes/near_field.py), compute form only: the lit frame
// with, per pixel, the irradiance field's light over the sectors the near search hid
// (ao.glsl NEAR_FIELD) replaced by what the search gathered there, both blurred and
// upsampled as the occlusion is (ao_upsample.glsl):
//     diffuse = albedo x (field x open share + near field)
// where the ambient pass put albedo x field. Nothing hidden: the lit frame as it was.
#include "gbuffer_surface.glsl"
#include "ao_upsample.glsl"
#include "irradiance_field.glsl"
uniform vec3 field_eye;         // the camera's world position: s.p is relative to it
uniform sampler2D u_near;       // the search's raw (irradiance gathered, share hidden)
uniform int u_step;
uniform sampler2D u_lit;        // the lit opaque frame (lit_copy.py)
#ifdef WRITE_AOVS
uniform sampler2D u_diffuse;    // the DiffInd render pass so far (passes/ambient.py)
#endif

// A screen pass's body (engine/gpu/screen.py): the lit frame and, with WRITE_AOVS,
// DiffInd, each with the same change.
void screen_pixel(ivec2 px, out vec4 frag, out vec4 aov_diffuse, out vec4 unused2,
                  out vec4 unused3) {
    aov_diffuse = unused2 = unused3 = vec4(0.0);
#ifdef WRITE_AOVS
    // Its own texel, read before this invocation stores it.
    aov_diffuse = texelFetch(u_diffuse, px, 0);
#endif
    frag = texelFetch(u_lit, px, 0);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) return;
    vec3 p = position_from_depth((vec2(px) + 0.5) / vec2(textureSize(g_depth, 0)), depth,
                                 inv_view_proj);
    vec4 near = upsampled(u_near, u_step, px, p, normalize(texelFetch(g_normal, px, 0).xyz));
    if (near.a <= 0.0) return;
    Surface s = gbuffer_surface(px, depth);
    vec3 E = field_irradiance_at(s.p + field_eye, s.n, s.v);
    vec3 change = brdf_diffuse(s) * (near.rgb - E * near.a) * bump_dome(s);
    frag.rgb += change;
    aov_diffuse.rgb += change;
}
