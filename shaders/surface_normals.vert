#version 330 core
#include "skinning.glsl"
// The skinning pass's surface-normal sum, first stage: each vertex of a deformed mesh
// without authored normals, deformed as skin.vert deforms it, with the point it is.
in vec3 in_pos;
in vec3 in_normal;
in vec4 in_tangent;
out vec3 v_pos;
flat out int v_point;
void main() {
    vec3 p = in_pos, n = in_normal, t = in_tangent.xyz;
    skin_vertex(p, n, t);
    v_pos = p;
    v_point = in_point;
}
