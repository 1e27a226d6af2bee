#version 330 core
#include "lib.glsl"
// A Points prim's sphere, or a round tube's piece (points.vert): the ray from the
// viewer through this fragment hits it at p, whose normal and depth are the
// surface's own, so points and curves intersect surfaces and one another correctly
// and are lit (and, POINTS_SHADOW, cast shadows) like meshes. G-buffer outputs as
// gbuffer.frag; a material's constants (no maps).
in vec3 v_pos;
flat in vec4 v_a;
flat in vec4 v_b;
uniform bool u_face_axis;
uniform vec3 u_axis;
uniform mat4 u_window;        // origin-relative -> (x, y, window depth, w)
#if defined(POINTS_SHADOW)
uniform bool radial;          // radial map: depth = distance / far from the origin
uniform float far;
#elif defined(POINTS_ID)
uniform int u_object;
out int rt_id;
#else
#ifdef POINTS_COLOUR
flat in vec3 v_colour;
#endif
layout(location = 0) out vec4 rt_base;
layout(location = 1) out vec4 rt_normal;
layout(location = 2) out vec4 rt_mat;
layout(location = 3) out vec4 rt_emit;
#ifdef WRITE_SMOOTH_NORMAL
layout(location = 4) out vec4 rt_smooth;     // as gbuffer.frag's: a sphere has no map
#define SHEEN_LOCATION 5
#else
#define SHEEN_LOCATION 4
#endif
#ifdef WRITE_SHEEN
layout(location = SHEEN_LOCATION) out vec4 rt_sheen;
uniform vec4 u_sheen;
#define INDEX_LOCATION (SHEEN_LOCATION + 1)
#else
#define INDEX_LOCATION SHEEN_LOCATION
#endif
#ifdef WRITE_INDEX
// As gbuffer.frag's: a Points prim has no pass index of its own.
layout(location = INDEX_LOCATION) out vec4 rt_index;
uniform int u_object;
uniform float u_material_index;
uniform float u_material_id;
#endif
uniform vec3 u_diffuse;
uniform float u_metallic;
uniform float u_roughness;
uniform float u_ior;
uniform vec3 u_emissive;
uniform float u_opacity;
uniform float u_clearcoat;
uniform float u_clearcoat_roughness;
#endif

const float NO_HIT = 3.4e38;

// The first root of the ray o + t d (|d| = 1) on the sphere (c, r), or NO_HIT.
float sphere_hit(vec3 o, vec3 d, vec3 c, float r) {
    vec3 oc = o - c;
    float b = dot(d, oc);
    float disc = b * b - (dot(oc, oc) - r * r);
    return disc < 0.0 ? NO_HIT : -b - sqrt(disc);
}

// The first hit of the ray o + t d (|d| = 1) on the hull of the spheres (a, ra) and
// (b, rb): the spheres, and the cone tangent to both between the circles where it
// touches them. The hull is convex, so its first hit is the first of the spheres'
// and the cone band's. In the (s along the axis u, q from it) plane the cone is
// s sin(beta) + q cos(beta) = ra, sin(beta) = (ra - rb) / L; it touches the spheres
// at s = ra sin(beta) and L + rb sin(beta). Returns t (NO_HIT: a miss) and the
// outward normal.
float hull_hit(vec3 o, vec3 d, vec3 a, float ra, vec3 b, float rb, out vec3 n) {
    // Solve near the primitive: o far from it would cancel digits (|o|^2 - r^2).
    float t0 = dot(0.5 * (a + b) - o, d);
    o += d * t0;
    float ta = sphere_hit(o, d, a, ra), tb = sphere_hit(o, d, b, rb);
    float t = min(ta, tb);
    n = t == ta ? (o + d * t - a) / ra : (o + d * t - b) / rb;
    vec3 ab = b - a;
    float len = length(ab);
    if (len > abs(ra - rb) * (1.0 + 1e-5)) {        // else one sphere holds the other
        vec3 u = ab / len;
        float sn = (ra - rb) / len, c2 = 1.0 - sn * sn;
        vec3 w = o - a;
        float s0 = dot(w, u), sd = dot(d, u);
        float e0 = ra - sn * s0;
        float qa = c2 - sd * sd;
        float qb = c2 * (dot(w, d) - s0 * sd) + e0 * sn * sd;
        float qc = c2 * (dot(w, w) - s0 * s0) - e0 * e0;
        float disc = qb * qb - qa * qc;
        if (disc >= 0.0 && abs(qa) > 1e-12) {
            float root = sqrt(disc);
            for (int i = 0; i < 2; ++i) {
                float tc = (-qb + (i == 0 ? -root : root)) / qa;
                float s = s0 + tc * sd;
                if (tc < t && s >= ra * sn && s <= len + rb * sn) {
                    t = tc;
                    vec3 radial = w + d * tc - u * s;
                    n = sn * u + sqrt(c2) * radial / max(length(radial), 1e-30);
                }
            }
        }
    }
    return t == NO_HIT ? NO_HIT : t0 + t;
}

void main() {
    vec3 d = u_face_axis ? u_axis : normalize(v_pos);
    float reach = distance(v_a.xyz, v_b.xyz) + 2.0 * max(v_a.w, v_b.w);
    vec3 o = u_face_axis ? v_pos - d * reach : vec3(0.0);
    vec3 normal;
    float t = hull_hit(o, d, v_a.xyz, v_a.w, v_b.xyz, v_b.w, normal);
    if (t == NO_HIT) discard;
    if (t < 0.0) discard;                      // the viewer is inside the surface
    vec3 p = o + d * t;
    vec4 w = u_window * vec4(p, 1.0);
#if defined(POINTS_SHADOW)
    gl_FragDepth = radial ? clamp(length(p) / far, 0.0, 1.0) : clamp(w.z / w.w, 0.0, 1.0);
#elif defined(POINTS_ID)
    gl_FragDepth = w.z / w.w;
    rt_id = u_object + 1;
#else
    gl_FragDepth = w.z / w.w;
    vec3 base = u_diffuse;
#ifdef POINTS_COLOUR
    base = v_colour;
#endif
    float f = (u_ior - 1.0) / (u_ior + 1.0);
    rt_base = vec4(clamp(base, 0.0, 1.0), u_opacity);
    rt_normal = vec4(normal, clamp(u_clearcoat_roughness, 0.0, 1.0));
    rt_mat = vec4(clamp(u_metallic, 0.0, 1.0), clamp(u_roughness, 0.0, 1.0), f * f,
                  clamp(u_clearcoat, 0.0, 1.0));
    rt_emit = vec4(clamp(u_emissive, 0.0, 60000.0), 0.0);   // .a: no base occlusion
#ifdef WRITE_SMOOTH_NORMAL
    rt_smooth = vec4(rt_normal.xyz, 0.0);
#endif
#ifdef WRITE_SHEEN
    rt_sheen = u_sheen;
#endif
#ifdef WRITE_INDEX
    rt_index = vec4(0.0, u_material_index, float(u_object + 1), u_material_id);
#endif
#endif
}
