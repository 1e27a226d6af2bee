#version 330 core
#include "lib.glsl"
// A Points prim's sphere (points.vert): the ray from the viewer through this fragment
// hits it at p, whose normal and depth are the sphere's own, so points intersect
// surfaces and one another correctly and are lit (and, POINTS_SHADOW, cast shadows)
// like meshes. G-buffer outputs as gbuffer.frag; a material's constants (no maps).
in vec3 v_pos;
flat in vec3 v_center;
flat in float v_radius;
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

void main() {
    vec3 d = u_face_axis ? u_axis : normalize(v_pos);
    vec3 o = u_face_axis ? v_pos - d * (2.0 * v_radius) : vec3(0.0);
    vec3 oc = o - v_center;
    float b = dot(d, oc);
    float disc = b * b - (dot(oc, oc) - v_radius * v_radius);
    if (disc < 0.0) discard;
    float t = -b - sqrt(disc);
    if (t < 0.0) discard;                      // the viewer is inside the sphere
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
    rt_normal = vec4((p - v_center) / v_radius, clamp(u_clearcoat_roughness, 0.0, 1.0));
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
