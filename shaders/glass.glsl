// The glass pass (engine/gpu/passes/glass.py): a transmissive surface's front faces,
// lit forward as the transparency pass lights its surfaces (forward.glsl), its diffuse
// share (1 - transmission) and its Fresnel reflection of the dome and the lights; and,
// in the AMBIENT draw, what it lets through: the refracted ray's radiance, tinted by the
// base colour, weighted by 1 - Fresnel at each interface.
//   TRACED  (GL 4.3) the ray is followed through the object's own surfaces with the ray
//           tracer: Snell at each, total internal reflection inside, up to
//           GLASS_INTERFACES; what the ray leaving it meets is read from the lit frame
//           where it is on screen and not hidden, else from the dome along the ray.
//   else    one interface, in screen space: the refracted ray runs as far as the opaque
//           surface behind the pixel lies, and reads the lit frame there (the dome off
//           screen).
// What lies behind is blurred by the roughness (a mip level of the lit frame, a
// roughness level of the prefiltered dome). The frame behind is the opaque one: a
// second glass object behind the first is not seen through it (docs/status.md).
// The output replaces the pixel (blended ONE, ONE_MINUS_SRC_ALPHA with alpha 1); the
// draws of further lights add their reflection (alpha 0).
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
flat in float v_object_id;      // 1 + the object's id (gbuffer.vert WRITE_INDEX)
uniform mat4 inv_view_proj;
uniform mat4 view_proj;         // camera-relative -> clip (gbuffer.vert's)
uniform vec3 cam_forward;
uniform bool cam_ortho;
uniform vec2 u_size;            // the target's size in pixels
uniform vec3 u_eye;             // the camera's world position (the tracer's frame)
uniform bool u_refract;         // whether light goes through (Cycles: not at 0 bounces)
uniform float u_behind_lods;    // mip levels of u_behind
uniform sampler2D u_behind;     // the lit opaque frame (mip-mapped)
uniform sampler2D u_opaque_depth;  // g_depth (not attached: the depth test is here)

#include "material.glsl"
#include "lights.glsl"
#include "environment.glsl"
#ifdef HAS_SHADOW
#include "shadow_lookup.glsl"
#endif
#include "forward.glsl"
#include "lit_frame.glsl"

#define GLASS_INTERFACES 8
// The least distance a traced ray goes from where it starts on a surface, relative to
// its distance from the camera: the front surface's position comes from its depth,
// within about this much, and must not be hit again.
#define GLASS_OFFSET 1.0e-3

out vec4 frag;

// The dome along d, blurred by roughness r as the reflections are (a lobe about d).
vec3 dome_along(vec3 d, float r) {
    if (!has_dome) return vec3(0.0);
    return r > 0.0 ? dome_specular(make_lobe(d, d, r, 1.0)) : dome_background(d);
}

// The camera-relative position of the opaque surface at window uv (none: far away).
vec3 opaque_at(vec2 uv, out bool found) {
    float depth = textureLod(u_opaque_depth, uv, 0.0).r;
    found = !is_background(depth);
    return position_from_depth(uv, depth, inv_view_proj);
}

// The lit frame at uv, blurred by roughness r.
vec3 frame_at(vec2 uv, float r) {
    return textureLod(u_behind, uv, r * u_behind_lods * 0.5).rgb;
}

#ifdef TRACED
// The traced triangles' corner normals, object space (passes/glass.py); zero: none.
layout(std430, binding = 14) readonly buffer GlassNormals { vec4 glass_normals[]; };

// The shading normal at a hit, world space, on the side of the triangle's own normal
// `flat_n` (unit, world): its corner normals interpolated, else flat_n.
vec3 hit_shading_normal(RtHit hit, vec3 flat_n) {
    int k = 3 * hit.triangle;
    vec2 b = hit.barycentric;
    vec3 n = (1.0 - b.x - b.y) * glass_normals[k].xyz + b.x * glass_normals[k + 1].xyz
           + b.y * glass_normals[k + 2].xyz;
    if (dot(n, n) < 1.0e-12) return flat_n;
    vec4 r0 = rt_instance(hit.instance, 0), r1 = rt_instance(hit.instance, 1),
         r2 = rt_instance(hit.instance, 2);
    n = normalize(n.x * r0.xyz + n.y * r1.xyz + n.z * r2.xyz);
    return dot(n, flat_n) < 0.0 ? -n : n;
}

// Whether the ray from camera-relative q along d meets something; L: what it meets, as
// the lit frame shows it where the hit is on screen and not hidden there, else the dome
// along the ray.
bool traced_radiance(vec3 q, vec3 d, float r, out vec3 L) {
    L = dome_along(d, r);
    vec2 uv;
    float t;
    int met = frame_hit(q, d, GLASS_OFFSET * (1.0 + length(q)), u_opaque_depth, uv, t);
    if (met == FRAME_SHOWN) L = frame_at(uv, r);
    return met != FRAME_ESCAPED;
}

vec3 radiance_along(vec3 q, vec3 d, float r) {
    vec3 L;
    traced_radiance(q, d, r, L);
    return L;
}

// Follows a ray inside the object from camera-relative q along d (weight: what it
// carries so far) until it leaves: Snell's law at each interface, total internal
// reflection, Fresnel's transmittance and the tint at each crossing. With `split`, the
// share the first interface the ray leaves by reflects back inside is handed out as
// a second ray (branch_q, branch_d, branch_weight; zero weight: none).
void through(inout vec3 q, inout vec3 d, inout vec3 weight, float eta, vec3 tint, bool split,
             out vec3 branch_q, out vec3 branch_d, out vec3 branch_weight) {
    branch_q = q;
    branch_d = d;
    branch_weight = vec3(0.0);
    int object = int(v_object_id) - 1;
    for (int i = 0; i < GLASS_INTERFACES; ++i) {
        RtHit hit;
        if (!rt_closest_hit(q + u_eye, d, GLASS_OFFSET * (1.0 + length(q)), RT_FAR, hit) ||
                rt_hit_object(hit) != object)
            break;                             // out of the object (or into another)
        q += hit.t * d;
        vec3 hn = rt_hit_normal(hit);
        bool leaving = dot(hn, d) > 0.0;       // the winding's normal points out
        if (leaving) hn = -hn;
        vec3 sn = hit_shading_normal(hit, hn);
        if (dot(sn, -d) > 0.0) hn = sn;        // smooth, where it still faces the ray
        float ratio = leaving ? eta : 1.0 / eta;
        float c = clamp(dot(-d, hn), 0.0, 1.0);
        float f = fresnel_dielectric(c, 1.0 / ratio);   // lib.glsl: n_t / n_i
        if (f >= 1.0) {                        // total internal reflection
            d = reflect(d, hn);
        } else {
            if (split && leaving) {
                branch_q = q;
                branch_d = reflect(d, hn);
                branch_weight = weight * f;
                split = false;
            }
            d = refract(d, hn, ratio);
            weight *= tint * (1.0 - f);
        }
    }
}

// Through the object: from camera-relative p (its front surface, normal n facing the
// viewer) along the view ray dir, the radiance it carries back. What the way out's
// first leaving interface reflects stays inside and leaves by another way, which is
// followed too (a clear body loses no light: Cycles' paths take those ways; dropped,
// the glass_sphere shot's ball was 4% darker than Cycles').
vec3 transmitted(vec3 p, vec3 n, vec3 dir, float eta, vec3 tint, float r) {
    float cos_i = clamp(dot(-dir, n), 0.0, 1.0);
    vec3 weight = tint * (1.0 - fresnel_dielectric(cos_i, eta));
    vec3 d = refract(dir, n, 1.0 / eta);
    vec3 q = p, bq, bd, bw, unused_q, unused_d, unused_w;
    through(q, d, weight, eta, tint, true, bq, bd, bw);
    vec3 L = weight * radiance_along(q, d, r);
    if (max(bw.r, max(bw.g, bw.b)) > 0.0) {
        through(bq, bd, bw, eta, tint, false, unused_q, unused_d, unused_w);
        L += bw * radiance_along(bq, bd, r);
    }
    return L;
}
#else
vec3 transmitted(vec3 p, vec3 n, vec3 dir, float eta, vec3 tint, float r) {
    float cos_i = clamp(dot(-dir, n), 0.0, 1.0);
    vec3 weight = tint * (1.0 - fresnel_dielectric(cos_i, eta));
    vec3 d = refract(dir, n, 1.0 / eta);
    bool found;
    vec3 o = opaque_at(gl_FragCoord.xy / u_size, found);
    vec2 uv;
    if (found && on_screen(p + d * length(o - p), uv)) return weight * frame_at(uv, r);
    return weight * dome_along(d, r);
}
#endif

void main() {
    // Behind an opaque surface (without bounces the glass is in the depth itself: the
    // same depth, within rounding, passes).
    float opaque = texelFetch(u_opaque_depth, ivec2(gl_FragCoord.xy), 0).r;
    if (nearer(opaque, gl_FragCoord.z * (1.0 + 1.0e-5))) discard;
    MaterialSample m = material_sample(v_uv, v_normal, v_tangent, gl_FrontFacing);
    vec3 p = position_from_depth(gl_FragCoord.xy / u_size, gl_FragCoord.z, inv_view_proj);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    // The diffuse layer keeps 1 - transmission of the base colour; the rest is the tint.
    Surface s = make_surface(p, m.n, v, vec4(m.base * (1.0 - u_transmission), 1.0), m.mat,
                             m.coat_roughness);
    s.smooth_n = m.smooth_n;
#ifdef SHEEN
    apply_sheen(s, m.sheen);
#endif
    vec3 c = forward_light(s, p, m.n, m.emissive);
#if defined(AMBIENT) && defined(TRACED)
    // The mirror ray meets the scene: the glass reflects that, not the dome (nothing
    // without bounces, as Cycles draws it).
    vec3 met;
    if (traced_radiance(p, reflect(-v, m.n), m.mat.y, met)) {
        vec3 dome_diffuse, dome_glossy;
        dome_light(s, vec2(1.0), dome_diffuse, dome_glossy);
        c += s.under_coat * s.spec_albedo * (u_refract ? met : vec3(0.0)) - dome_glossy;
    }
#endif
#ifdef AMBIENT
    if (u_refract && u_transmission > 0.0) {
        float eta = max(u_ior, 1.0 + 1.0e-4);
        c += u_transmission * s.under_coat *
             transmitted(p, m.n, -v, eta, m.base, m.mat.y);
    }
    frag = vec4(c, 1.0);
#else
    frag = vec4(c, 0.0);
#endif
}
