#version 330 core
// G-buffer geometry: static meshes, and skinned ones as the skinning pass left them
// this frame (the same vertex layout), placed by their object's matrices relative to
// the camera (objects.glsl). view_proj is the camera-relative, reversed-depth
// projection; clip distance 0 is the camera's far plane (engine/view.py).
#include "objects.glsl"
in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
uniform mat4 view_proj;
uniform float u_far;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
#ifdef PATTERN_NORMAL
out vec3 v_position;        // camera-relative: a bump node's screen-space derivatives
#endif
#ifdef COLOR_ATTRIBUTE
in vec4 in_color;           // the colour attribute a network reads (engine/gpu/stores.py)
out vec4 v_color;
#endif
#ifdef PATTERN_GENERATED
in vec3 in_generated;       // Blender's Generated coordinates (engine/usd/mesh.py)
out vec3 v_generated;
#endif
#ifdef WRITE_INDEX
flat out float v_object_index;
flat out float v_object_id;     // 1 + the object's id; 0 is the background
#endif
void main() {
    mat4 model = object_model();
    vec4 position = model * vec4(in_pos, 1.0);
    gl_Position = view_proj * position;
#ifdef PATTERN_NORMAL
    v_position = position.xyz;
#endif
#ifdef COLOR_ATTRIBUTE
    v_color = in_color;
#endif
#ifdef PATTERN_GENERATED
    v_generated = in_generated;
#endif
    gl_ClipDistance[0] = u_far - gl_Position.w;
    v_normal = object_normal_matrix() * in_normal;
    v_uv = in_uv;
    v_tangent = vec4(mat3(model) * in_tangent.xyz, in_tangent.w);
#ifdef WRITE_INDEX
    v_object_index = object_pass_index();
    v_object_id = float(OBJECT_ID + 1);
#endif
}
