#version 330 core
// A light volume. One light: `mvp` places its mesh. LIGHTS_INSTANCED: many shadowless
// sphere lights in one draw; `mvp` is the view-projection and each instance carries
// its light (see engine/renderer.py, _draw_batched_lights), handed on unchanged.
in vec3 in_pos;
uniform mat4 mvp;
#ifdef LIGHTS_INSTANCED
in vec4 i_pos_range;      // position, volume radius
in vec4 i_color_radius;   // intensity I [W/sr], sphere radius
in vec4 i_axis_cos;       // spot axis, cos(half angle)
in vec4 i_params;         // spot blend, diffuse, specular, flags (1 soft falloff, 2 spot)
flat out vec4 v_pos_range;
flat out vec4 v_color_radius;
flat out vec4 v_axis_cos;
flat out vec4 v_params;
#endif
void main() {
#ifdef LIGHTS_INSTANCED
    v_pos_range = i_pos_range;
    v_color_radius = i_color_radius;
    v_axis_cos = i_axis_cos;
    v_params = i_params;
    gl_Position = mvp * vec4(i_pos_range.xyz + in_pos * i_pos_range.w, 1.0);
#else
    gl_Position = mvp * vec4(in_pos, 1.0);
#endif
}
