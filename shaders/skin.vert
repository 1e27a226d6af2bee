#version 330 core
#include "skinning.glsl"
// The skinning pass: transform feedback of each skinned mesh's vertices, once per
// frame, into the dynamic store in the static layout (position, normal, uv, tangent),
// in the space the mesh is drawn in (skeleton space when it has joints). Every later
// pass draws the result as plain geometry; tests read it back.
in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
out vec3 out_pos;
out vec3 out_normal;
out vec2 out_uv;
out vec4 out_tangent;
#ifdef SKIN_SURFACE_NORMALS
// Run on the deformed vertices (no SKIN_JOINTS or SKIN_SHAPES): their normals become
// the surface's own, as engine/usd/mesh.py's smooth normals (area-weighted per point).
uniform sampler2D u_deformed;    // the deformed vertices, 3 RGBA texels (12 floats) each
uniform sampler2D u_incidence;   // engine/skin.py incidence_texels
uniform int u_points;
const int DEFORMED_TEX_W = 4095; // engine/gpu/passes/skinning.py: a multiple of 3
vec3 deformed_position(int v) {
    int i = 3 * v;
    return texelFetch(u_deformed, ivec2(i % DEFORMED_TEX_W, i / DEFORMED_TEX_W), 0).xyz;
}
#endif
void main() {
    vec3 p = in_pos, n = in_normal, t = in_tangent.xyz;
    skin_vertex(p, n, t);
#ifdef SKIN_SURFACE_NORMALS
    vec4 range = flat_texel(u_incidence, in_point);
    vec3 sum = vec3(0.0);
    for (int i = 0; i < int(range.y); ++i) {
        ivec3 tri = ivec3(flat_texel(u_incidence, u_points + int(range.x) + i).xyz);
        vec3 a = deformed_position(tri.x);
        sum += cross(deformed_position(tri.y) - a, deformed_position(tri.z) - a);
    }
    n = sum / max(length(sum), 1e-30);
    // The tangent is made orthogonal to the new normal again.
    vec3 tt = t - n * dot(n, t);
    float t_len = length(tt);
    if (t_len > 0.0) t = tt / t_len;
#endif
    out_pos = p;
    out_normal = n;
    out_uv = in_uv;
    out_tangent = vec4(t, in_tangent.w);
}
