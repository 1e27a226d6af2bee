#version 330 core
// Shadow casters: positions only, skinned as the G-buffer skins them (skinning.glsl),
// so a posed character casts its posed shadow.
#include "skinning.glsl"
in vec3 in_pos;
uniform mat4 model;
uniform mat4 view_proj;
out vec3 v_world;
void main() {
    vec3 p = in_pos, n = vec3(0.0, 0.0, 1.0), t = vec3(1.0, 0.0, 0.0);
#ifdef SKINNED
    skin_vertex(p, n, t);
#endif
    vec4 w = model * vec4(p, 1.0);
    v_world = w.xyz;
    gl_Position = view_proj * w;
}
