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
uniform sampler2D u_surface_normals;   // per point: sum of its triangles' area normals
#endif
void main() {
    vec3 p = in_pos, n = in_normal, t = in_tangent.xyz;
    skin_vertex(p, n, t);
#ifdef SKIN_SURFACE_NORMALS
    // As engine/usd/mesh.py's smooth normals of a mesh without authored ones; the
    // tangent is made orthogonal to the new normal again.
    vec3 a = flat_texel(u_surface_normals, in_point).xyz;
    n = a / max(length(a), 1e-30);
    vec3 tt = t - n * dot(n, t);
    float t_len = length(tt);
    if (t_len > 0.0) t = tt / t_len;
#endif
    out_pos = p;
    out_normal = n;
    out_uv = in_uv;
    out_tangent = vec4(t, in_tangent.w);
}
