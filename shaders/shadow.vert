#version 330 core
// Shadow casters: positions only (and UVs for the alpha test). Skinned meshes arrive
// posed (the skinning pass ran once this frame), so a posed character casts its posed
// shadow. Positions are relative to the map's anchor (the light, or the sun's anchor:
// origin.glsl), so a map's precision does not depend on the distance to the world
// origin.
#include "objects.glsl"
in vec3 in_pos;
uniform mat4 view_proj;
// An object that casts nothing into this map: an emissive mesh's own, into its light's
// (engine/emitters.py); -1 for none.
uniform int skip_object = -1;
out vec3 v_world;              // anchor-relative
#ifdef ALPHA_TEST
in vec2 in_uv;
out vec2 v_uv;
#endif
void main() {
    vec4 w = object_model() * vec4(in_pos, 1.0);
    v_world = w.xyz;
#ifdef ALPHA_TEST
    v_uv = in_uv;
#endif
    gl_Position = OBJECT_ID == skip_object ? vec4(0.0, 0.0, 2.0, 1.0)   // clipped
                                           : view_proj * w;
}
