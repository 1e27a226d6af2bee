#version 330 core
// Depth only. Radial maps (spot, cube) store distance / far, the same quantity on
// every cube face, so the lookup compares radial distances and PCSS reads blocker
// distances without un-projecting. Ortho (sun) depth is linear already.
in vec3 v_world;
uniform bool radial;
uniform vec3 light_pos;        // anchor-relative (0 for radial maps)
uniform float far;
void main() {
    if (radial) gl_FragDepth = clamp(length(v_world - light_pos) / far, 0.0, 1.0);
    else gl_FragDepth = gl_FragCoord.z;
}
