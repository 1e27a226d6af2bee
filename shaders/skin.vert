#version 330 core
#include "skinning.glsl"
// The skinning pass's transform-feedback form (GL 3.3 and 4.1, and compute off): each
// skinned mesh's vertices, once per frame, into the dynamic store in the static layout
// (position, normal, uv, tangent), in the space the mesh is drawn in (skeleton space
// when it has joints). Every later pass draws the result as plain geometry; tests read
// it back. The deformation is skinning.glsl's, shared with skin.comp.
in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
in int in_point;                // the mesh point this vertex is (per-point data)
out vec3 out_pos;
out vec3 out_normal;
out vec2 out_uv;
out vec4 out_tangent;

#if defined(SKIN_JOINTS) && !defined(SKIN_JOINTS_TEX)
in ivec4 in_joints0;
in vec4 in_weights0;
#ifdef SKIN_JOINTS8
in ivec4 in_joints1;
in vec4 in_weights1;
#endif
void vertex_influences(int h, out ivec4 j, out vec4 w) {
#ifdef SKIN_JOINTS8
    if (h == 1) { j = in_joints1; w = in_weights1; return; }
#endif
    j = in_joints0;
    w = in_weights0;
}
#endif

#ifdef SKIN_SURFACE_NORMALS
// Run on a copy of the deformed vertices (no SKIN_JOINTS or SKIN_SHAPES), made into a
// texture: a vertex shader cannot read the buffer it is written into.
uniform sampler2D u_deformed;    // the deformed vertices, 3 RGBA texels (12 floats) each
const int DEFORMED_TEX_W = 4095; // engine/gpu/passes/skinning.py: a multiple of 3
vec3 deformed_position(int v) {
    int i = 3 * v;
    return texelFetch(u_deformed, ivec2(i % DEFORMED_TEX_W, i / DEFORMED_TEX_W), 0).xyz;
}
#endif

void main() {
    vec3 p = in_pos, n = in_normal, t = in_tangent.xyz;
#ifdef SKIN_SURFACE_NORMALS
    surface_frame(in_point, n, t);
#else
    skin_vertex(in_point, p, n, t);
#endif
    out_pos = p;
    out_normal = n;
    out_uv = in_uv;
    out_tangent = vec4(t, in_tangent.w);
}
