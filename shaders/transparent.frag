#version 330 core
#include "lib.glsl"
// The transparency pass (engine/gpu/passes/transparency.py): a blended surface, lit
// forward with the deferred passes' own functions (material.glsl, lights.glsl,
// environment.glsl, shadow_lookup.glsl) and composited over the HDR target,
// premultiplied. Cycles mixes the whole Principled BSDF, emission included, with a
// transparent BSDF by alpha, so everything the surface sends is scaled by alpha:
//   AMBIENT  dome + emission + the unshadowed lights in light_rows, blended "over"
//            (ONE, ONE_MINUS_SRC_ALPHA): rgb = alpha * radiance, a = alpha
//   else     more lights (HAS_SHADOW: exactly one, with its shadow map), added
//            (ONE, ONE): rgb = alpha * radiance, a = 0
// Over is linear in its source, so splitting one surface's light over several
// additive draws composites it exactly as one draw would.
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;
uniform vec2 u_size;            // the target's size in pixels
uniform float u_opaque_alpha;   // texels at or above it are the G-buffer's (Material.alpha)

#include "material.glsl"
#include "lights.glsl"
#include "environment.glsl"
#ifdef HAS_SHADOW
#include "shadow_lookup.glsl"
#endif

#define MAX_FORWARD_LIGHTS 32
uniform int n_lights;
uniform int light_rows[MAX_FORWARD_LIGHTS];

out vec4 frag;

void main() {
    float alpha = clamp(material_alpha(v_uv), 0.0, 1.0);
    if (alpha <= 0.0 || alpha >= u_opaque_alpha) discard;
    MaterialSample m = material_sample(v_uv, v_normal, v_tangent, gl_FrontFacing);
    vec3 p = position_from_depth(gl_FragCoord.xy / u_size, gl_FragCoord.z, inv_view_proj);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    Surface s = make_surface(p, m.n, v, vec4(m.base, alpha), m.mat, m.coat_roughness);
    s.smooth_n = m.smooth_n;
#ifdef SHEEN
    apply_sheen(s, m.sheen);
#endif
    vec3 c = vec3(0.0), diffuse, glossy;
#ifdef HAS_SHADOW
    vec3 ng = cross(dFdx(p), dFdy(p));               // geometric normal (contact shadows)
    ng = dot(ng, ng) > 0.0 ? normalize(ng) * sign(dot(ng, m.n) + 1e-30) : m.n;
#endif
#ifdef AMBIENT
    dome_light(s, vec2(1.0), diffuse, glossy);      // no ambient occlusion: it is screen space
    c += m.emissive + diffuse + glossy;
#endif
    for (int i = 0; i < n_lights; ++i) {
        load_light(light_rows[i], cam_forward);
        light_reflected(s, diffuse, glossy);
        vec3 r = diffuse + glossy;
#ifdef HAS_SHADOW
        if (max(r.r, max(r.g, r.b)) > 0.0)
            r *= light_shadow(p, m.n, ng, dot(p, cam_forward));
#endif
        c += r;
    }
    // NaN or Inf goes through, as the light pass lets it: the resolve pass counts it.
#ifdef AMBIENT
    frag = vec4(alpha * c, alpha);
#else
    frag = vec4(alpha * c, 0.0);
#endif
}
