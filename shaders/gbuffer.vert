#version 330 core
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
    gl_Position = view_proj * (model * vec4(in_pos, 1.0));
    v_normal = normal_matrix * in_normal;
    v_uv = in_uv;
    v_tangent = vec4(mat3(model) * in_tangent.xyz, in_tangent.w);
}
