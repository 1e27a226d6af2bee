#version 330 core
#include "skinning.glsl"
// Transform feedback: skinned position and normal in the space the mesh is drawn
// in (skeleton space when it has joints), for tests against UsdSkel's CPU skinning.
in vec3 in_pos;
in vec3 in_normal;
out vec3 out_pos;
out vec3 out_normal;
void main() {
    vec3 p = in_pos, n = in_normal, t = vec3(0.0);
#ifdef SKINNED
    skin_vertex(p, n, t);
#endif
    out_pos = p;
    out_normal = n;
}
