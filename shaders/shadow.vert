#version 330 core
// Shadow casters: position only. (Skinned casters extend this stage.)
in vec3 in_pos;
uniform mat4 model;
uniform mat4 view_proj;
out vec3 v_world;
void main() {
    vec4 w = model * vec4(in_pos, 1.0);
    v_world = w.xyz;
    gl_Position = view_proj * w;
}
