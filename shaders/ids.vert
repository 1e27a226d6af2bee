#version 330 core
// Object ids (the resolve pass's diagnosis of non-finite pixels): each object's id
// plus one (0: nothing drawn), placed as the G-buffer places it.
#include "objects.glsl"
in vec3 in_pos;
uniform mat4 view_proj;
uniform float u_far;
flat out int v_id;
void main() {
    gl_Position = view_proj * (object_model() * vec4(in_pos, 1.0));
    gl_ClipDistance[0] = u_far - gl_Position.w;
    v_id = OBJECT_ID + 1;
}
