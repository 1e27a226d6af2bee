#version 330 core
// Shadow casters: positions only. Skinned meshes arrive posed (the skinning pass ran
// once this frame), so a posed character casts its posed shadow. Positions are
// relative to the map's anchor (the light, or the sun's anchor: origin.glsl), so a
// map's precision does not depend on the distance to the world origin.
#include "objects.glsl"
in vec3 in_pos;
uniform mat4 view_proj;
out vec3 v_world;              // anchor-relative
void main() {
    vec4 w = object_model() * vec4(in_pos, 1.0);
    v_world = w.xyz;
    gl_Position = view_proj * w;
}
