#version 330 core
// A light volume. One light: `mvp` places its mesh. LIGHTS_INSTANCED: many shadowless
// sphere lights in one draw; `mvp` is the camera-relative view-projection and each
// instance is a row of the light table (engine/gpu/passes/lights.py), its sphere
// scaled to its range.
in vec3 in_pos;
uniform mat4 mvp;
#ifdef LIGHTS_INSTANCED
#include "origin.glsl"
#include "light_table.glsl"
in int i_light;
flat out int v_light;
#endif
void main() {
#ifdef LIGHTS_INSTANCED
    v_light = i_light;
    vec4 pos_range = light_table(i_light, 0);
    vec3 pos = rebase(pos_range.xyz, light_table(i_light, 7).xyz);
    gl_Position = mvp * vec4(pos + in_pos * pos_range.w, 1.0);
#else
    gl_Position = mvp * vec4(in_pos, 1.0);
#endif
}
