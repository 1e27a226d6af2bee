#version 330 core
#include "skinning.glsl"
in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
uniform mat4 model;
uniform mat4 view_proj;
uniform mat3 normal_matrix;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
void main() {
    vec3 p = in_pos, n = in_normal, t = in_tangent.xyz;
#ifdef SKINNED
    skin_vertex(p, n, t);
#endif
    gl_Position = view_proj * (model * vec4(p, 1.0));
    v_normal = normal_matrix * n;
    v_uv = in_uv;
    v_tangent = vec4(mat3(model) * t, in_tangent.w);
}
