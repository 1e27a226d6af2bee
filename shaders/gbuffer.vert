#version 330 core
// G-buffer geometry: static meshes, and skinned ones as the skinning pass left them
// this frame (the same vertex layout), placed by their object's matrices.
#include "objects.glsl"
in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
uniform mat4 view_proj;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
void main() {
    mat4 model = object_model();
    gl_Position = view_proj * (model * vec4(in_pos, 1.0));
    v_normal = object_normal_matrix() * in_normal;
    v_uv = in_uv;
    v_tangent = vec4(mat3(model) * in_tangent.xyz, in_tangent.w);
}
