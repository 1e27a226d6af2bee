#version 330 core
// The skinning pass's surface-normal sum: one triangle's area normal, added (blending
// ONE, ONE) into its point's texel.
in vec3 g_area_normal;
out vec4 frag;
void main() { frag = vec4(g_area_normal, 0.0); }
